#include "devices/trajectory.h"

#include <sstream>

#include <gtest/gtest.h>

#include "tests/support/test_support.h"

namespace ld::devices {
namespace {

const std::string kHeader = "t,hand,tool,tip_x,tip_y,tip_z,dir_x,dir_y,dir_z,up_x,up_y,up_z,jaw,pedal\n";

std::string errorOf(const std::string& text) {
  try {
    parseTrajectoryCsv(text, "stroke.csv");
  } catch (const ParseError& e) {
    return e.what();
  }
  return "";
}

TEST(Trajectory, ParsesSamplesAndNormalisesFrames) {
  const auto tr = parseTrajectoryCsv(kHeader +
                                         "0,right,hook,1,2,3,0,0,-2,1,0,0.5,0,1\n"
                                         "0.001,left,grasper,4,5,6,0,0,-1,0,1,0,0.5,0\n",
                                     "a.csv");
  ASSERT_EQ(tr.samples.size(), 2u);
  const auto& s = tr.samples[0];
  EXPECT_EQ(s.hand, instruments::Hand::Right);
  EXPECT_EQ(s.tool, instruments::Tool::Hook);
  EXPECT_TRUE(ld::test::nearVec(s.pose.tip, Eigen::Vector3d(1, 2, 3), 0));
  EXPECT_TRUE(ld::test::nearVec(s.pose.dir, Eigen::Vector3d(0, 0, -1), 1e-15));
  // up made perpendicular to dir and unit.
  EXPECT_TRUE(ld::test::nearVec(s.pose.up, Eigen::Vector3d(1, 0, 0), 1e-15));
  EXPECT_TRUE(s.pose.pedal);
  EXPECT_EQ(tr.samples[1].tool, instruments::Tool::Grasper);
  EXPECT_DOUBLE_EQ(tr.samples[1].pose.jaw, 0.5);
  EXPECT_DOUBLE_EQ(tr.duration(), 0.001);
  EXPECT_EQ(tr.hand(instruments::Hand::Left).size(), 1u);
}

TEST(Trajectory, RoundTripsThroughWriter) {
  Trajectory tr;
  for (int i = 0; i < 5; ++i) {
    PoseSample s;
    s.t = i * 0.01;
    s.pose.tip = {0.1 * i, -0.3, 2.5 + 1e-9 * i};
    s.pose.pedal = i % 2;
    tr.samples.push_back(s);
  }
  std::ostringstream out;
  writeTrajectoryCsv(tr, out);
  const auto back = parseTrajectoryCsv(out.str(), "mem");
  ASSERT_EQ(back.samples.size(), tr.samples.size());
  for (std::size_t i = 0; i < tr.samples.size(); ++i) {
    EXPECT_EQ(back.samples[i].t, tr.samples[i].t);
    EXPECT_EQ(back.samples[i].pose.tip, tr.samples[i].pose.tip);
    EXPECT_EQ(back.samples[i].pose.pedal, tr.samples[i].pose.pedal);
  }
}

TEST(Trajectory, BadInputNamesFileLineAndReason) {
  EXPECT_EQ(errorOf(""), "stroke.csv:1: empty file: no header");
  EXPECT_NE(errorOf("t,x\n").find("stroke.csv:1: expected header"), std::string::npos);
  EXPECT_NE(errorOf(kHeader + "0,right,hook,1,2,3\n").find("stroke.csv:2: expected 14 columns, found 6"),
            std::string::npos);
  EXPECT_NE(errorOf(kHeader + "0,right,hook,1,2,abc,0,0,-1,1,0,0,0,0\n").find("stroke.csv:2: column tip_z"),
            std::string::npos);
  EXPECT_NE(errorOf(kHeader + "0,right,hook,1,2,nan,0,0,-1,1,0,0,0,0\n").find(":2: column tip_z is not finite"),
            std::string::npos);
  EXPECT_NE(errorOf(kHeader + "0,middle,hook,1,2,3,0,0,-1,1,0,0,0,0\n").find(":2: hand 'middle'"), std::string::npos);
  EXPECT_NE(errorOf(kHeader + "0,left,saw,1,2,3,0,0,-1,1,0,0,0,0\n").find(":2: tool 'saw'"), std::string::npos);
  EXPECT_NE(errorOf(kHeader + "1,left,hook,1,2,3,0,0,-1,1,0,0,0,0\n0.5,left,hook,1,2,3,0,0,-1,1,0,0,0,0\n")
                .find(":3: time goes backwards"),
            std::string::npos);
  EXPECT_NE(errorOf(kHeader + "0,left,hook,1,2,3,0,0,0,1,0,0,0,0\n").find(":2: dir is a zero vector"),
            std::string::npos);
  EXPECT_NE(errorOf(kHeader + "0,left,hook,1,2,3,0,0,1,0,0,2,0,0\n").find(":2: up is parallel to dir"),
            std::string::npos);
  EXPECT_NE(errorOf(kHeader + "0,left,hook,1,2,3,0,0,1,1,0,0,2,0\n").find(":2: jaw must lie"), std::string::npos);
  EXPECT_NE(errorOf(kHeader + "0,left,hook,1,2,3,0,0,1,1,0,0,0,0.5\n").find(":2: pedal must be 0 or 1"),
            std::string::npos);
}

TEST(Trajectory, ToleratesCommentsBlankLinesCrlfAndBom) {
  const auto tr = parseTrajectoryCsv(
      "\xEF\xBB\xBF# recorded\r\n" +
          std::string("t, hand ,tool,tip_x,tip_y,tip_z,dir_x,dir_y,dir_z,up_x,up_y,up_z,jaw,pedal\r\n") +
          "\r\n0,left,scalpel,0,0,0,0,0,-1,1,0,0,0,0\r\n",
      "crlf.csv");
  ASSERT_EQ(tr.samples.size(), 1u);
  EXPECT_EQ(tr.samples[0].tool, instruments::Tool::Scalpel);
}

TEST(Instruments, GeometryFollowsDesign) {
  instruments::Pose p;
  p.tip = {1, 2, 3};
  p.dir = {0, 0, -1};
  p.up = {1, 0, 0};
  auto scalpel = instruments::segments(instruments::Tool::Scalpel, p);
  ASSERT_EQ(scalpel.size(), 1u);
  EXPECT_TRUE(ld::test::nearVec(scalpel[0].b, Eigen::Vector3d(1, 2, 23), 1e-12));
  auto hook = instruments::segments(instruments::Tool::Hook, p);
  ASSERT_EQ(hook.size(), 2u);
  EXPECT_TRUE(ld::test::nearVec(hook[0].a, Eigen::Vector3d(-3, 2, 3), 1e-12));  // elbow B = tip - 4 up
  EXPECT_TRUE(ld::test::nearVec(hook[1].a, Eigen::Vector3d(-3, 2, 9), 1e-12));  // B - 6 dir
  p.jaw = 0.0;
  auto closed = instruments::segments(instruments::Tool::Grasper, p);
  ASSERT_EQ(closed.size(), 2u);
  EXPECT_TRUE(ld::test::nearVec(closed[0].b, p.tip, 1e-12));
  EXPECT_TRUE(ld::test::nearVec(closed[1].b, p.tip, 1e-12));
  p.jaw = 1.0;
  auto open = instruments::segments(instruments::Tool::Grasper, p);
  const Eigen::Vector3d j0 = (open[0].b - open[0].a).normalized(), j1 = (open[1].b - open[1].a).normalized();
  EXPECT_TRUE(ld::test::near(std::acos(j0.dot(j1)), 60.0 * M_PI / 180.0, 1e-12));
}

}  // namespace
}  // namespace ld::devices
