#include "curriculum/polyline_csv.h"

#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "curriculum/curriculum_error.h"

namespace ld::curriculum {
namespace {

std::string errorOf(const std::string& text) {
  try {
    (void)parsePolylineCsv(text, "drawn.csv");
  } catch (const FormatError& e) {
    return e.what();
  }
  return "";
}

TEST(PolylineCsv, ReadsPiecesCommentsAndBom) {
  const Polyline p = parsePolylineCsv("\xEF\xBB\xBF# a path\nx,y,z,stop\n0,0,0,0\n1, 2 ,3,1\n\n4,5,6,0\r\n", "d.csv");
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p[1].p, Eigen::Vector3d(1, 2, 3));
  EXPECT_TRUE(p[1].stop);
  EXPECT_FALSE(p[0].stop);
  EXPECT_TRUE(p[2].stop);  // the last point always ends a piece
  const Polyline q = parsePolylineCsv("x,y,z\n0,0,0\n1,0,0\n", "d.csv");
  ASSERT_EQ(q.size(), 2u);
  EXPECT_FALSE(q[0].stop);
}

TEST(PolylineCsv, BadInputNamesFileLineAndReason) {
  EXPECT_EQ(errorOf(""), "drawn.csv:1: empty file: expected the header x,y,z[,stop]");
  EXPECT_EQ(errorOf("x,y\n"), "drawn.csv:1: expected the header x,y,z[,stop]");
  EXPECT_EQ(errorOf("x,y,z\n"), "drawn.csv:2: no points");
  EXPECT_EQ(errorOf("x,y,z\n1,2,3\n1,2\n"), "drawn.csv:3: 2 columns, expected 3");
  EXPECT_EQ(errorOf("x,y,z\n1,abc,3\n"), "drawn.csv:2: column y: 'abc' is not a number");
  EXPECT_EQ(errorOf("x,y,z\n1,2,inf\n"), "drawn.csv:2: column z is not finite");
  EXPECT_EQ(errorOf("x,y,z,stop\n1,2,3,2\n"), "drawn.csv:2: column stop: '2' is not 0 or 1");
}

TEST(PolylineCsv, WriterRoundTripsExactly) {
  const Polyline p{{{0.1, 1.0 / 3.0, -2e-9}, false}, {{5, 6, 7}, true}, {{8, 9, 10}, true}};
  std::ostringstream out;
  writePolylineCsv(p, out);
  const Polyline q = parsePolylineCsv(out.str(), "w.csv");
  ASSERT_EQ(q.size(), p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_EQ(q[i].p, p[i].p);
    EXPECT_EQ(q[i].stop, p[i].stop);
  }
}

}  // namespace
}  // namespace ld::curriculum
