// Order statistics and CSV helpers of the store.
#include "database/stats.h"

#include <gtest/gtest.h>

#include "database/connection_url.h"
#include "database/csv.h"

namespace {

using namespace ld::db;

TEST(Summarize, QuartilesInterpolateLikeNumpy) {
  // numpy.percentile([7, 1, 3, 10], [25, 50, 75]) = [2.5, 5.0, 7.75]
  const Summary s = summarize({7, 1, 3, 10});
  EXPECT_EQ(s.n, 4u);
  EXPECT_DOUBLE_EQ(s.q1, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 5.0);
  EXPECT_DOUBLE_EQ(s.q3, 7.75);
  EXPECT_DOUBLE_EQ(s.min, 1);
  EXPECT_DOUBLE_EQ(s.max, 10);
  const Summary one = summarize({42});
  EXPECT_DOUBLE_EQ(one.q1, 42);
  EXPECT_DOUBLE_EQ(one.q3, 42);
  EXPECT_EQ(summarize({}).n, 0u);
}

TEST(Csv, QuotesAndNeutralisesFormulas) {
  EXPECT_EQ(csvText("plain"), "plain");
  EXPECT_EQ(csvText("a,b"), "\"a,b\"");
  EXPECT_EQ(csvText("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(csvText("=1+1"), "'=1+1");
  EXPECT_EQ(csvText("@SUM(A1)"), "'@SUM(A1)");
  EXPECT_EQ(csvText("line\nbreak"), "\"line\nbreak\"");
  EXPECT_EQ(csvNumber(0.1), "0.1");
  EXPECT_EQ(csvNumber(-2.5), "-2.5");
  std::vector<std::pair<std::string, nlohmann::json>> flat;
  flattenJson({{"a", {{"b", 1}, {"c", {{"d", true}}}}}, {"e", {1, 2}}}, "", flat);
  ASSERT_EQ(flat.size(), 3u);
  EXPECT_EQ(flat[0].first, "a.b");
  EXPECT_EQ(flat[1].first, "a.c.d");
  EXPECT_EQ(flat[2].first, "e");
}

TEST(ConnectionUrl, Forms) {
  auto pg = parseConnectionUrl("postgresql://kim:s3cret@db.example.org:6543/residency");
  EXPECT_EQ(pg.kind, ConnectionInfo::Kind::Postgres);
  EXPECT_EQ(pg.user, "kim");
  EXPECT_EQ(pg.password, "s3cret");
  EXPECT_EQ(pg.host, "db.example.org");
  EXPECT_EQ(pg.port, 6543);
  EXPECT_EQ(pg.database, "residency");
  EXPECT_EQ(pg.display().find("s3cret"), std::string::npos);
  EXPECT_EQ(parseConnectionUrl("postgresql://h/db").port, 5432);
  auto s = parseConnectionUrl("sqlite:///var/lib/ld/a%20b.db");
  EXPECT_EQ(s.kind, ConnectionInfo::Kind::Sqlite);
  EXPECT_EQ(s.path, "/var/lib/ld/a b.db");
  EXPECT_EQ(parseConnectionUrl("data/store.db").path, "data/store.db");
  EXPECT_THROW(parseConnectionUrl("ftp://x/y"), InvalidArgument);
  EXPECT_THROW(parseConnectionUrl("sqlite://"), InvalidArgument);
  EXPECT_THROW(parseConnectionUrl("postgresql://h:99999/db"), InvalidArgument);
}

}  // namespace
