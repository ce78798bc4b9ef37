#include "devices/csv_text.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace ld::devices::csv {
namespace {

TEST(CsvText, RecordsSkipBomBlankAndCommentLinesAndKeepLineNumbers) {
  std::vector<std::pair<long, std::string>> seen;
  const long lines = forEachRecord("\xEF\xBB\xBF# comment\n\n  a, b \r\n\t\nc\n",
                                   [&](long n, std::string_view line) { seen.emplace_back(n, std::string(line)); });
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0], (std::pair<long, std::string>{3, "a, b"}));
  EXPECT_EQ(seen[1], (std::pair<long, std::string>{5, "c"}));
  EXPECT_EQ(lines, 6);  // the empty line after the last newline counts
  EXPECT_EQ(forEachRecord("", [](long, std::string_view) { FAIL(); }), 1);
}

TEST(CsvText, FieldsAreTrimmedAndEmptyFieldsKept) {
  const auto f = splitFields(" 1 ,\t2,, x\r");
  ASSERT_EQ(f.size(), 4u);
  EXPECT_EQ(f[0], "1");
  EXPECT_EQ(f[1], "2");
  EXPECT_EQ(f[2], "");
  EXPECT_EQ(f[3], "x");
  EXPECT_EQ(splitFields("").size(), 1u);
}

TEST(CsvText, NumbersMustBeWholeAndFinite) {
  double v = 0;
  EXPECT_EQ(parseNumber("-1.5e3", v), NumberStatus::Ok);
  EXPECT_DOUBLE_EQ(v, -1500.0);
  EXPECT_EQ(parseNumber("1.5mm", v), NumberStatus::NotANumber);
  EXPECT_EQ(parseNumber("", v), NumberStatus::NotANumber);
  EXPECT_EQ(parseNumber("nan", v), NumberStatus::NotFinite);
  EXPECT_EQ(parseNumber("inf", v), NumberStatus::NotFinite);
  EXPECT_EQ(numberProblem("tip_x", "1.5mm", NumberStatus::NotANumber), "column tip_x: '1.5mm' is not a number");
  EXPECT_EQ(numberProblem("z", "nan", NumberStatus::NotFinite), "column z is not finite");
  EXPECT_EQ(numberProblem("z", "1", NumberStatus::Ok), "");
}

TEST(CsvText, MissingFileIsReported) {
  std::string text;
  EXPECT_FALSE(readFile("/nonexistent/lapdissect/file.csv", text));
}

}  // namespace
}  // namespace ld::devices::csv
