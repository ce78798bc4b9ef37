#include <cmath>
#include <cstdio>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/sim/io/io_test_util.h"
#include "tests/support/test_support.h"

namespace ld::io {
namespace {

using test::parseErrorOf;
using test::soupOf;
using ::testing::HasSubstr;

constexpr double kPi = 3.14159265358979323846;

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string v2Triangle(const std::string& wrapBefore, const std::string& wrapAfter, const std::string& ifsExtra = "") {
  return "#VRML V2.0 utf8\n" + wrapBefore +
         "Shape { geometry IndexedFaceSet { coord Coordinate { point [ 1 0 0, 0 1 0, 0 0 0 ] } coordIndex [ 2 0 1 -1 "
         "] " +
         ifsExtra + " } }\n" + wrapAfter;
}

TEST(VrmlReader, Vrml2TransformAppliesTranslationRotationScale) {
  const auto soup = soupOf(Format::Vrml, v2Triangle("Transform { translation 1 2 3 rotation 0 0 1 " + num(kPi / 2) +
                                                        " scale 2 2 2 children [\n",
                                                    "] }\n"));
  ASSERT_EQ(soup.points.size(), 3u);
  // (1,0,0) scaled to (2,0,0), turned to (0,2,0), moved to (1,4,3).
  EXPECT_TRUE(ld::test::nearVec(soup.points[0], Eigen::Vector3d(1, 4, 3), 1e-9));
  EXPECT_TRUE(ld::test::nearVec(soup.points[2], Eigen::Vector3d(1, 2, 3), 1e-12));
}

TEST(VrmlReader, Vrml2TransformCenterAndScaleOrientation) {
  // A quarter turn about the centre c = (1,0,0): p -> c + R (p - c).
  const auto a = soupOf(
      Format::Vrml, v2Triangle("Transform { center 1 0 0 rotation 0 0 1 " + num(kPi / 2) + " children [\n", "] }\n"));
  ASSERT_EQ(a.points.size(), 3u);
  EXPECT_TRUE(ld::test::nearVec(a.points[0], Eigen::Vector3d(1, 0, 0), 1e-9));
  EXPECT_TRUE(ld::test::nearVec(a.points[2], Eigen::Vector3d(1, -1, 0), 1e-9));  // c + R(p - c), p = 0
  // Scale 2 along x, with the scale axes turned 90 degrees: stretches y instead.
  const auto b =
      soupOf(Format::Vrml,
             v2Triangle("Transform { scale 2 1 1 scaleOrientation 0 0 1 " + num(kPi / 2) + " children [\n", "] }\n"));
  EXPECT_TRUE(ld::test::nearVec(b.points[0], Eigen::Vector3d(1, 0, 0), 1e-9));
  EXPECT_TRUE(ld::test::nearVec(b.points[1], Eigen::Vector3d(0, 2, 0), 1e-9));
}

TEST(VrmlReader, NestedTransformsComposeAndDoNotLeakToSiblings) {
  const std::string text =
      "#VRML V2.0 utf8\n"
      "Transform { translation 10 0 0 children [\n"
      "  Transform { scale 3 3 3 children Shape { geometry IndexedFaceSet { coord Coordinate { point [1 0 0, 0 1 0, 0 "
      "0 "
      "0] } coordIndex [0 1 2] } } }\n"
      "] }\n"
      "Shape { geometry IndexedFaceSet { coord Coordinate { point [5 5 5, 6 5 5, 5 6 5] } coordIndex [0 1 2] } }\n";
  const auto s = soupOf(Format::Vrml, text);
  ASSERT_EQ(s.points.size(), 6u);
  EXPECT_TRUE(ld::test::nearVec(s.points[0], Eigen::Vector3d(13, 0, 0), 1e-12));
  EXPECT_TRUE(ld::test::nearVec(s.points[3], Eigen::Vector3d(5, 5, 5), 1e-12));
}

TEST(VrmlReader, Vrml1StateTranslationRotationScaleMatrixAndSeparatorScope) {
  const std::string text =
      "#VRML V1.0 ascii\n"
      "Separator {\n"
      "  Coordinate3 { point [ 1 0 0, 0 1 0, 0 0 0 ] }\n"
      "  Separator { Translation { translation 5 0 0 } Translation { translation 0 1 0 } IndexedFaceSet { coordIndex [ "
      "0, 1, 2, -1 ] } }\n"
      "  Separator { Rotation { rotation 0 0 1 " +
      num(kPi) +
      " } Scale { scaleFactor 2 2 2 } IndexedFaceSet { coordIndex [ 0, 1, 2, -1 ] } }\n"
      "  Separator { MatrixTransform { matrix 1 0 0 0  0 1 0 0  0 0 1 0  7 8 9 1 } IndexedFaceSet { coordIndex [ 0, 1, "
      "2 ] } }\n"
      "  IndexedFaceSet { coordIndex [ 0, 1, 2, -1 ] }\n"
      "}\n";
  ImportReport rep;
  const auto s = soupOf(Format::Vrml, text, &rep);
  EXPECT_EQ(rep.vrmlVersion, 1);
  ASSERT_EQ(s.points.size(), 12u);
  EXPECT_TRUE(ld::test::nearVec(s.points[0], Eigen::Vector3d(6, 1, 0), 1e-12));  // both translations
  EXPECT_TRUE(ld::test::nearVec(s.points[3], Eigen::Vector3d(-2, 0, 0), 1e-9));  // scaled then turned
  EXPECT_TRUE(ld::test::nearVec(s.points[6], Eigen::Vector3d(8, 8, 9), 1e-12));  // Inventor row-vector matrix
  EXPECT_TRUE(ld::test::nearVec(s.points[9], Eigen::Vector3d(1, 0, 0), 1e-12));  // Separators restored the state
}

TEST(VrmlReader, Vrml1TransformNodeModifiesState) {
  const std::string text =
      "#VRML V1.0 ascii\nSeparator { Coordinate3 { point [1 0 0, 0 1 0, 0 0 0] }\n"
      "Transform { translation 0 0 4 scaleFactor 2 2 2 }\nIndexedFaceSet { coordIndex [0,1,2,-1] } }\n";
  const auto s = soupOf(Format::Vrml, text);
  ASSERT_EQ(s.points.size(), 3u);
  EXPECT_TRUE(ld::test::nearVec(s.points[0], Eigen::Vector3d(2, 0, 4), 1e-12));
}

TEST(VrmlReader, DefUseInstancesGetOwnVerticesUnderDifferentTransforms) {
  const std::string text =
      "#VRML V2.0 utf8\n"
      "DEF T Shape { geometry IndexedFaceSet { coord Coordinate { point [1 0 0, 0 1 0, 0 0 0] } coordIndex [0 1 2 -1] "
      "} "
      "}\n"
      "Transform { translation 0 0 5 children USE T }\n"
      "Transform { translation 0 0 5 children [ USE T ] }\n";
  const auto s = soupOf(Format::Vrml, text);
  // Three instances; the last two share one transform and so share vertices.
  EXPECT_EQ(s.triangles.size(), 3u);
  EXPECT_EQ(s.points.size(), 6u);
}

TEST(VrmlReader, SharedCoordinateNodeSharesVerticesAcrossFaceSets) {
  const std::string text =
      "#VRML V2.0 utf8\n"
      "Shape { geometry IndexedFaceSet { coord DEF C Coordinate { point [0 0 0, 1 0 0, 1 1 0, 0 1 0] } coordIndex [0 1 "
      "2 -1] } }\n"
      "Shape { geometry IndexedFaceSet { coord USE C coordIndex [0 2 3 -1] } }\n";
  const auto s = soupOf(Format::Vrml, text);
  EXPECT_EQ(s.points.size(), 4u);
  EXPECT_EQ(computeStats(s).edges, 5u);  // one surface, not two loose triangles
}

TEST(VrmlReader, SwitchWhichChildSelects) {
  const std::string shapes =
      "Separator { Coordinate3 { point [0 0 0, 1 0 0, 0 1 0] } IndexedFaceSet { coordIndex [0,1,2] } }\n"
      "Separator { Coordinate3 { point [0 0 0, 1 0 0, 0 1 0, 1 1 0] } IndexedFaceSet { coordIndex [0,1,3,2] } }\n";
  auto count = [&](const std::string& which) {
    return soupOf(Format::Vrml, "#VRML V1.0 ascii\nSwitch { " + which + "\n" + shapes + "}\n").triangles.size();
  };
  EXPECT_EQ(count(""), 0u);  // default -1: nothing
  EXPECT_EQ(count("whichChild -1"), 0u);
  EXPECT_EQ(count("whichChild 0"), 1u);
  EXPECT_EQ(count("whichChild 1"), 2u);
  EXPECT_EQ(count("whichChild -3"), 3u);
  // VRML 2.0 Switch: whichChoice over choice.
  const auto v2 = soupOf(Format::Vrml,
                         "#VRML V2.0 utf8\nSwitch { whichChoice 1 choice [ Group {} Shape { geometry IndexedFaceSet { "
                         "coord Coordinate { point [0 0 0, 1 0 0, 0 1 0] } coordIndex [0 1 2] } } ] }\n");
  EXPECT_EQ(v2.triangles.size(), 1u);
}

TEST(VrmlReader, CcwFalseAndClockwiseShapeHintsReverseFaces) {
  // An open triangle keeps the file's orientation, so reversal is visible in the normal.
  const auto ccw = soupOf(Format::Vrml, v2Triangle("", ""));
  const auto cw = soupOf(Format::Vrml, v2Triangle("", "", "ccw FALSE"));
  ASSERT_EQ(ccw.triangles.size(), 1u);
  ASSERT_EQ(cw.triangles.size(), 1u);
  EXPECT_GT(test::faceNormal(ccw, ccw.triangles[0]).z(), 0);
  EXPECT_LT(test::faceNormal(cw, cw.triangles[0]).z(), 0);

  const std::string v1 =
      "#VRML V1.0 ascii\nSeparator { Coordinate3 { point [0 0 0, 1 0 0, 0 1 0] }\n"
      "Separator { ShapeHints { vertexOrdering CLOCKWISE } IndexedFaceSet { coordIndex [0,1,2,-1] } }\n"
      "Separator { ShapeHints { vertexOrdering COUNTERCLOCKWISE } IndexedFaceSet { coordIndex [0,1,2,-1] } }\n"
      "IndexedFaceSet { coordIndex [0,1,2,-1] } }\n";
  const auto s = soupOf(Format::Vrml, v1);
  ASSERT_EQ(s.triangles.size(), 3u);
  // Same transform and coordinates: the three faces share vertices; the clockwise one
  // is reversed (its normal points down) and the others are not.
  int down = 0, up = 0;
  for (const auto& t : s.triangles) (test::faceNormal(s, t).z() < 0 ? down : up)++;
  EXPECT_EQ(down, 1);
  EXPECT_EQ(up, 2);
}

TEST(VrmlReader, MirroringTransformKeepsFacesOutward) {
  // A closed tetrahedron under scale -1 1 1 must still face outward.
  const std::string text =
      "#VRML V2.0 utf8\nTransform { scale -1 1 1 children Shape { geometry IndexedFaceSet { coord Coordinate { point "
      "[0 "
      "0 0, 1 0 0, 0 1 0, 0 0 1] } coordIndex [0 2 1 -1 0 1 3 -1 0 3 2 -1 1 2 3 -1] } } }\n";
  ImportReport rep;
  const auto s = soupOf(Format::Vrml, text, &rep);
  EXPECT_GT(test::signedVolume(s), 0);
  EXPECT_EQ(rep.flippedFaces, 0u);  // the reader already reversed them
}

TEST(VrmlReader, HeaderVersionFromFirstTokensOnly) {
  ImportReport rep;
  soupOf(Format::Vrml, "#VRML V2.0 utf8 CosmoWorlds V1.0\nGroup {}\n", &rep);
  EXPECT_EQ(rep.vrmlVersion, 2);
  EXPECT_TRUE(rep.warnings.empty());
  ImportReport rep1;
  soupOf(Format::Vrml, "#VRML V1.0 ascii made with V2.0 tools\nSeparator {}\n", &rep1);
  EXPECT_EQ(rep1.vrmlVersion, 1);
}

TEST(VrmlReader, ByteOrderMarkTolerated) {
  ImportReport rep;
  const auto s = soupOf(Format::Vrml, "\xEF\xBB\xBF" + v2Triangle("", ""), &rep);
  EXPECT_EQ(s.triangles.size(), 1u);
  EXPECT_EQ(rep.vrmlVersion, 2);
  EXPECT_TRUE(rep.warnings.empty());
}

TEST(VrmlReader, MissingHeaderReadLenientlyWithWarning) {
  ImportReport rep;
  const auto s =
      soupOf(Format::Vrml,
             "DEF X Transform { children Shape { geometry IndexedFaceSet { coord Coordinate { point [0 0 0, 1 "
             "0 0, 0 1 0] } coordIndex [0 1 2 -1] } } }\n",
             &rep);
  EXPECT_EQ(s.triangles.size(), 1u);
  ASSERT_FALSE(rep.warnings.empty());
  EXPECT_THAT(rep.warnings[0], HasSubstr("test:1: no '#VRML"));
  EXPECT_EQ(rep.vrmlVersion, 2);
}

TEST(VrmlReader, UnknownNodesAndFieldsSkippedPrimitivesWarned) {
  ImportReport rep;
  const std::string text =
      "#VRML V2.0 utf8\n"
      "FancyNode { size 1 2 3 flags [ A B ] mode ON title \"a } b\" child FancyNode { } }\n"
      "Shape { geometry Sphere { radius 2 } }\n"
      "Shape { appearance Appearance { material Material { diffuseColor 0.66, 0.01, 0.01 } }\n"
      "  geometry IndexedFaceSet { weirdField TRUE coord Coordinate { point [0 0 0, 1 0 0, 0 1 0] } coordIndex [0 1 2 "
      "-1] } }\n"
      "ROUTE a.b TO c.d\n";
  const auto s = soupOf(Format::Vrml, text, &rep);
  EXPECT_EQ(s.triangles.size(), 1u);
  std::string all;
  for (const auto& w : rep.warnings) all += w + "\n";
  EXPECT_THAT(all, HasSubstr("unknown node FancyNode"));
  EXPECT_THAT(all, HasSubstr("test:3: Sphere"));
}

TEST(VrmlReader, CommasAnywhereUnbracketedPointAndEmptyNodes) {
  const std::string text =
      "#VRML V1.0 ascii\n"
      "Separator { Coordinate3 { } IndexedFaceSet { } Coordinate3 { point [] } IndexedFaceSet { coordIndex [] }\n"
      "Coordinate3 { point 1 2 3 } IndexedFaceSet { coordIndex [] }\n"
      "Coordinate3 { point [ 0,0,0, 1,0,0,, 1,1,0, 0,1,0, ] }\n"
      "IndexedFaceSet { coordIndex [ 0, 1, 2, 3, -1, ] } }\n";
  const auto s = soupOf(Format::Vrml, text);
  EXPECT_EQ(s.points.size(), 4u);
  EXPECT_EQ(s.triangles.size(), 2u);
  const auto one =
      soupOf(Format::Vrml,
             "#VRML V1.0 ascii\nSeparator { Coordinate3 { point 1 2 3 } IndexedFaceSet { coordIndex [0, 0, "
             "0] } }\n");
  EXPECT_EQ(one.triangles.size(), 0u);  // one point: a degenerate polygon, dropped
}

TEST(VrmlReader, PolygonsOfAnySizeTriangulated) {
  // A regular 12-gon (ten triangles, area preserved) and a non-convex L-shaped hexagon.
  std::string pts, idx;
  for (int i = 0; i < 12; ++i) {
    pts += std::to_string(std::cos(2 * kPi * i / 12)) + " " + std::to_string(std::sin(2 * kPi * i / 12)) + " 0, ";
    idx += std::to_string(i) + " ";
  }
  const auto s = soupOf(Format::Vrml, "#VRML V2.0 utf8\nShape { geometry IndexedFaceSet { coord Coordinate { point [" +
                                          pts + "] } coordIndex [" + idx + "-1] } }\n");
  EXPECT_EQ(s.triangles.size(), 10u);
  EXPECT_TRUE(ld::test::near(computeStats(s).area, 3.0, 1e-5));  // 12-gon of radius 1: area 3
  const auto l =
      soupOf(Format::Vrml,
             "#VRML V2.0 utf8\nShape { geometry IndexedFaceSet { coord Coordinate { point [0 0 0, 2 0 0, 2 1 "
             "0, 1 1 0, 1 2 0, 0 2 0] } coordIndex [0 1 2 3 4 5 -1] } }\n");
  EXPECT_EQ(l.triangles.size(), 4u);
  EXPECT_TRUE(ld::test::near(computeStats(l).area, 3.0, 1e-12));  // no triangle outside the L
  for (const auto& t : l.triangles) EXPECT_GT(test::faceNormal(l, t).z(), 0);
}

TEST(VrmlReader, MalformedInputGivesFileLineReason) {
  const auto err = [](const std::string& text) { return parseErrorOf([&] { parseVrml(text, "bad.wrl"); }); };
  EXPECT_THAT(err("#VRML V2.0 utf8\nGroup {\n children [\n"), HasSubstr("bad.wrl:3: unbalanced brackets"));
  EXPECT_THAT(err("#VRML V2.0 utf8\nGroup {\n"), HasSubstr("bad.wrl:2: unbalanced braces"));
  EXPECT_THAT(err("#VRML V2.0 utf8\nGroup { }\n}\n"), HasSubstr("bad.wrl:3: unbalanced braces"));
  EXPECT_THAT(err("#VRML V2.0 utf8\nWorldInfo { title \"abc\n\n"), HasSubstr("bad.wrl:2: unterminated string"));
  EXPECT_THAT(err(v2Triangle("", "").replace(v2Triangle("", "").find("2 0 1"), 5, "2 0 7")),
              HasSubstr("bad.wrl:2: coordIndex 7 out of range (3 points)"));
  EXPECT_THAT(err("#VRML V2.0 utf8\nShape { geometry IndexedFaceSet { coord Coordinate {\n point [ 0 0 0, nan 1 0, 0 "
                  "1 0 ] } coordIndex [0 1 2] } }\n"),
              HasSubstr("bad.wrl:3: non-finite number 'nan'"));
  EXPECT_THAT(err("#VRML V2.0 utf8\nShape { geometry IndexedFaceSet { coord Coordinate { point [ 0 0 0, 1 0 ] } "
                  "coordIndex [0 1 2] } }\n"),
              HasSubstr("not a multiple of 3"));
  EXPECT_THAT(err("#VRML V2.0 utf8\nShape { geometry IndexedFaceSet { coord Coordinate { point [ 0 0 0 ] } coordIndex "
                  "[0 x 2] } }\n"),
              HasSubstr("bad.wrl:2: expected an integer in coordIndex"));
  EXPECT_THAT(err("#VRML V2.0 utf8\nTransform { translation 1 2 }\n"), HasSubstr("bad.wrl:2: translation needs 3"));
  EXPECT_THAT(err("#VRML V2.0 utf8\n" + std::string(5000, '[')), HasSubstr("bad.wrl:2:"));
  std::string deep = "#VRML V2.0 utf8\n";
  for (int i = 0; i < 2000; ++i) deep += "Group { children ";
  EXPECT_THAT(err(deep), HasSubstr("bad.wrl:2: nodes nested too deeply"));
  EXPECT_THAT(err("\x1f\x8b\x08"), HasSubstr("gzip"));
}

TEST(VrmlReader, UseOfUndefinedNameWarns) {
  ImportReport rep;
  const auto s = soupOf(Format::Vrml, "#VRML V2.0 utf8\nTransform { children [ USE Missing ] }\n", &rep);
  EXPECT_TRUE(s.triangles.empty());
  ASSERT_EQ(rep.warnings.size(), 1u);
  EXPECT_THAT(rep.warnings[0], HasSubstr("test:2: USE of undefined name 'Missing'"));
}

TEST(VrmlReader, InstancingBlowUpIsBounded) {
  // Each level uses the previous one twice: 2^40 instances must stop with an error.
  // (An empty leaf keeps the test quick under the sanitizers; the limit counts visits.)
  std::string t = "#VRML V2.0 utf8\nDEF L0 Group { }\n";
  for (int i = 1; i <= 40; ++i)
    t += "DEF L" + std::to_string(i) + " Group { children [ USE L" + std::to_string(i - 1) + " USE L" +
         std::to_string(i - 1) + " ] }\n";
  EXPECT_THAT(parseErrorOf([&] { parseVrml(t, "big.wrl"); }), HasSubstr("big.wrl:0: too many node instances"));
}

}  // namespace
}  // namespace ld::io
