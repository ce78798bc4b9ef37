// OBJ, STL, PLY and OFF readers on small inline files, good and bad.
#include <cstring>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/sim/io/io_test_util.h"
#include "tests/support/test_support.h"

namespace ld::io {
namespace {

using test::parseErrorOf;
using test::soupOf;
using ::testing::HasSubstr;

// A unit tetrahedron, outward faces.
const Eigen::Vector3d kTet[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
const int kTetFaces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};

void expectClosedTetra(const TriangleSoup& s) {
  const auto st = computeStats(s);
  EXPECT_EQ(st.vertices, 4u);
  EXPECT_EQ(st.triangles, 4u);
  EXPECT_EQ(st.edges, 6u);
  EXPECT_TRUE(st.closed);
  EXPECT_TRUE(st.manifold);
  EXPECT_EQ(st.euler, 2);
  EXPECT_TRUE(ld::test::near(test::signedVolume(s), 1.0 / 6.0, 1e-12));
}

// ---- OBJ ------------------------------------------------------------------------

TEST(ObjReader, FaceFormsNegativeIndicesAndSkippedRecords) {
  const std::string text =
      "# comment\nmtllib x.mtl\no thing\nv 0 0 0\nv 1 0 0\nv 0 1 0 1.0\nv 0 0 1 0.5 0.5 0.5\nvn 0 0 1\nvt 0 0\n"
      "g grp\nusemtl m\ns 1\nf 1/1/1 3/1/1 2/1/1\nf 1//1 2//1 4//1\nf -4 -1 -2\nf 2/1 3/1 4/1\nl 1 2\n";
  ImportReport rep;
  const auto s = soupOf(Format::Obj, text, &rep);
  expectClosedTetra(s);
  EXPECT_TRUE(rep.warnings.empty());
}

TEST(ObjReader, QuadsAndUnreferencedVertices) {
  const std::string text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 9 9 9\nf 1 2 3 4\n";
  ImportReport rep;
  const auto s = soupOf(Format::Obj, text, &rep);
  EXPECT_EQ(s.points.size(), 4u);
  EXPECT_EQ(s.triangles.size(), 2u);
  EXPECT_EQ(rep.droppedVertices, 1u);
}

TEST(ObjReader, Malformed) {
  const auto err = [](const std::string& t) { return parseErrorOf([&] { parseObj(t, "bad.obj"); }); };
  EXPECT_THAT(err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n"), HasSubstr("bad.obj:4: face index '4' out of range"));
  EXPECT_THAT(err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"), HasSubstr("bad.obj:4: face index '0' out of range"));
  EXPECT_THAT(err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n"), HasSubstr("bad.obj:4:"));
  EXPECT_THAT(err("v 0 0\n"), HasSubstr("bad.obj:1: unexpected end of line, expected vertex coordinate"));
  EXPECT_THAT(err("v 0 0 0\nv nan 0 0\n"), HasSubstr("bad.obj:2: non-finite vertex coordinate 'nan'"));
  EXPECT_THAT(err("v 0 0 0\nv 1 0 0\nf 1 2\n"), HasSubstr("bad.obj:3: face with 2 corners"));
  EXPECT_THAT(err("v 0 0 0\nv 1 0 0\nv 1 1 1\nf 1 x 2\n"), HasSubstr("bad.obj:4: bad face index 'x'"));
  EXPECT_THAT(err("v 1e999 0 0\n"), HasSubstr("bad.obj:1: expected vertex coordinate"));
}

// ---- STL ------------------------------------------------------------------------

std::string asciiStl() {
  std::string s = "solid tet\n";
  for (const auto& f : kTetFaces) {
    s += "  facet normal 0 0 0\n    outer loop\n";
    for (int k : f)
      s += "      vertex " + std::to_string(kTet[k].x()) + " " + std::to_string(kTet[k].y()) + " " +
           std::to_string(kTet[k].z()) + "\n";
    s += "    endloop\n  endfacet\n";
  }
  return s + "endsolid tet\n";
}

std::string binaryStl(const std::string& header, std::uint32_t announced, int facets = 4) {
  std::string s = header;
  s.resize(80, ' ');
  s.append(reinterpret_cast<const char*>(&announced), 4);
  for (int f = 0; f < facets; ++f) {
    float rec[12] = {0};
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) rec[3 + 3 * c + k] = static_cast<float>(kTet[kTetFaces[f % 4][c]][k]);
    s.append(reinterpret_cast<const char*>(rec), sizeof rec);
    s.append(2, '\0');
  }
  return s;
}

TEST(StlReader, AsciiWeldsCorners) {
  ImportReport rep;
  const auto s = soupOf(Format::Stl, asciiStl(), &rep);
  expectClosedTetra(s);
  EXPECT_EQ(rep.weldedVertices, 8u);  // 12 corners -> 4 vertices
}

TEST(StlReader, BinaryEvenWithSolidHeader) {
  expectClosedTetra(soupOf(Format::Stl, binaryStl("COLOR=xyz MATERIAL=abc", 4)));
  expectClosedTetra(soupOf(Format::Stl, binaryStl("solid but binary", 4)));
}

TEST(StlReader, Malformed) {
  const auto err = [](const std::string& t) { return parseErrorOf([&] { parseStl(t, "bad.stl"); }); };
  EXPECT_THAT(err(binaryStl("x", 5)), HasSubstr("bad.stl:0: binary STL announces 5 triangles (334 bytes) but the file "
                                                "has 284 bytes"));
  EXPECT_THAT(err(binaryStl("x", 4).substr(0, 200)), HasSubstr("announces 4 triangles"));
  EXPECT_THAT(err(std::string(50, 'x')), HasSubstr("bad.stl:0: truncated binary STL"));
  std::string nan = binaryStl("x", 4);
  const float q = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(&nan[84 + 50 + 12], &q, 4);
  EXPECT_THAT(err(nan), HasSubstr("triangle 1 (byte 134) has a non-finite coordinate"));
  const std::string a = asciiStl();
  EXPECT_THAT(err(a.substr(0, a.size() / 2)), HasSubstr("bad.stl:"));
  EXPECT_THAT(err(a.substr(0, a.size() - 13)), HasSubstr("missing 'endsolid'"));
  EXPECT_THAT(err("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 nan\n"),
              HasSubstr("bad.stl:4: non-finite vertex coordinate"));
  EXPECT_THAT(err("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid\n"),
              HasSubstr("bad.stl:2: facet with 2 vertices"));
}

// ---- PLY ------------------------------------------------------------------------

std::string plyHeader(const std::string& format, const std::string& extraBefore = "") {
  return "ply\nformat " + format +
         " 1.0\ncomment tetra\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n" + extraBefore +
         "element face 4\nproperty list uchar int vertex_indices\nend_header\n";
}

template <class T>
void putBytes(std::string& s, T v, bool bigEndian) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (bigEndian) std::reverse(b, b + sizeof(T));
  s.append(b, sizeof(T));
}

std::string binaryPly(bool be) {
  std::string s = plyHeader(be ? "binary_big_endian" : "binary_little_endian");
  for (const auto& p : kTet)
    for (int k = 0; k < 3; ++k) putBytes(s, static_cast<float>(p[k]), be);
  for (const auto& f : kTetFaces) {
    putBytes(s, static_cast<std::uint8_t>(3), be);
    for (int k : f) putBytes(s, static_cast<std::int32_t>(k), be);
  }
  return s;
}

std::string asciiPlyBody() { return "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"; }

TEST(PlyReader, AsciiAndBinaryBothEndians) {
  expectClosedTetra(soupOf(Format::Ply, plyHeader("ascii") + asciiPlyBody()));
  expectClosedTetra(soupOf(Format::Ply, binaryPly(false)));
  expectClosedTetra(soupOf(Format::Ply, binaryPly(true)));
}

TEST(PlyReader, UnknownElementsSkippedAnywhere) {
  // An unknown element between vertices and faces, with a list property.
  const std::string text =
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty "
      "double z\nproperty double mass\nelement 3d_element 2\nproperty list uint uint "
      "vertex_indices\nelement face 4\nproperty list uchar int vertex_indices\nelement material "
      "1\nproperty double young\nend_header\n"
      "0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n4 0 1 2 3\n4 3 2 1 0\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 "
      "3\n1e9\n";
  ImportReport rep;
  expectClosedTetra(soupOf(Format::Ply, text, &rep));
  ASSERT_EQ(rep.warnings.size(), 2u);
  EXPECT_THAT(rep.warnings[0], HasSubstr("skipped element '3d_element' (2 rows)"));
}

TEST(PlyReader, ElementWithoutPropertiesHoldsNothing) {
  // Found by the fuzzer: billions of empty rows once looped for minutes (rows of nothing
  // consume no bytes, so no size check bounds them). Both encodings.
  for (const char* format : {"ascii", "binary_little_endian"}) {
    std::string text = std::string("ply\nformat ") + format +
                       " 1.0\nelement note 4444444444\nelement vertex 4\nproperty float x\nproperty float "
                       "y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n";
    if (std::string(format) == "ascii")
      text += asciiPlyBody();
    else
      text = text + binaryPly(false).substr(plyHeader("binary_little_endian").size());
    ImportReport rep;
    expectClosedTetra(soupOf(Format::Ply, text, &rep));
    ASSERT_FALSE(rep.warnings.empty()) << format;
    EXPECT_THAT(rep.warnings[0], HasSubstr("skipped element 'note' (4444444444 rows)")) << format;
  }
}

TEST(PlyReader, TwoDElementUsedWhenNoFaces) {
  const std::string text =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty "
      "double z\nelement 2d_element 1\nproperty list uint uint vertex_indices\nend_header\n0 0 0\n1 "
      "0 0\n0 1 0\n3 0 1 2\n";
  ImportReport rep;
  EXPECT_EQ(soupOf(Format::Ply, text, &rep).triangles.size(), 1u);
  ASSERT_FALSE(rep.warnings.empty());
  EXPECT_THAT(rep.warnings.back(), HasSubstr("using '2d_element' as faces"));
}

TEST(PlyReader, Malformed) {
  const auto err = [](const std::string& t) { return parseErrorOf([&] { parsePly(t, "bad.ply"); }); };
  const std::string good = plyHeader("ascii") + asciiPlyBody();
  EXPECT_THAT(err(good.substr(0, good.size() - 9)), HasSubstr("bad.ply:17: unexpected end of file in element 'face'"));
  EXPECT_THAT(err(plyHeader("ascii") + "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 4\n"),
              HasSubstr("bad.ply:16: vertex index 4 in element 'face' row 1 out of range (4 vertices)"));
  EXPECT_THAT(err(plyHeader("ascii") + "0 0 0\nnan 0 0\n"), HasSubstr("bad.ply:12: non-finite number 'nan'"));
  EXPECT_THAT(err("ply\nformat weird 1.0\n"), HasSubstr("bad.ply:2: unknown PLY format"));
  EXPECT_THAT(err("plx\n"), HasSubstr("bad.ply:1: not a PLY file"));
  EXPECT_THAT(err("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"), HasSubstr("no 'end_header'"));
  const std::string bin = binaryPly(false);
  EXPECT_THAT(err(bin.substr(0, bin.size() - 3)),
              HasSubstr("bad.ply:0: list in element 'face' row 3 runs past the end of the file"));
  std::string cutInVertex = bin.substr(0, bin.find("end_header\n") + 11 + 20);
  EXPECT_THAT(err(cutInVertex), HasSubstr("bad.ply:0: element 'vertex' announces 4 rows, more than the file holds"));
  std::string bigList = bin;
  bigList[bigList.size() - 13] = static_cast<char>(250);  // last face claims 250 corners
  EXPECT_THAT(err(bigList), HasSubstr("runs past the end of the file"));
  std::string lying = plyHeader("binary_little_endian");
  lying.replace(lying.find("vertex 4"), 8, "vertex 400000000");
  EXPECT_THAT(err(lying), HasSubstr("more than the file holds"));
}

// ---- OFF ------------------------------------------------------------------------

TEST(OffReader, CubeOfQuadsWithCommentsAndColours) {
  const std::string text =
      "OFF\n# a cube\n8 6 12\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n"
      "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4 255 0 0\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n";
  const auto s = soupOf(Format::Off, text);
  const auto st = computeStats(s);
  EXPECT_EQ(st.vertices, 8u);
  EXPECT_EQ(st.triangles, 12u);
  EXPECT_TRUE(st.closed);
  EXPECT_TRUE(ld::test::near(test::signedVolume(s), 1.0, 1e-12));
  EXPECT_TRUE(ld::test::near(st.area, 6.0, 1e-12));
}

TEST(OffReader, CountsOnHeaderLineAndMissingHeaderWarns) {
  EXPECT_EQ(soupOf(Format::Off, "OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").triangles.size(), 1u);
  ImportReport rep;
  EXPECT_EQ(soupOf(Format::Off, "3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", &rep).triangles.size(), 1u);
  ASSERT_EQ(rep.warnings.size(), 1u);
  EXPECT_THAT(rep.warnings[0], HasSubstr("test:1: no OFF header"));
}

TEST(OffReader, Malformed) {
  const auto err = [](const std::string& t) { return parseErrorOf([&] { parseOff(t, "bad.off"); }); };
  EXPECT_THAT(err("OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n"),
              HasSubstr("bad.off:5: unexpected end of file: 3 of 4 vertices"));
  EXPECT_THAT(err("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), HasSubstr("1 of 2 faces read"));
  EXPECT_THAT(err("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"), HasSubstr("bad.off:6: vertex index 3 out of range"));
  EXPECT_THAT(err("OFF\n3 1 0\n0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n"),
              HasSubstr("bad.off:4: non-finite vertex coordinate"));
  EXPECT_THAT(err("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n"), HasSubstr("bad.off:6: face has fewer than the 4"));
  EXPECT_THAT(err("OFF\n-3 1 0\n"), HasSubstr("negative element count"));
  EXPECT_THAT(err("OFF BINARY\n"), HasSubstr("binary OFF is not supported"));
  EXPECT_THAT(err(""), HasSubstr("bad.off:1: empty file"));
  // A huge announced count must fail on the missing data, not try to allocate it.
  EXPECT_THAT(err("OFF\n999999999 999999999 0\n0 0 0\n"), HasSubstr("unexpected end of file"));
}

}  // namespace
}  // namespace ld::io
