// readMesh / writeMesh: every shared data file against SOURCES.md, round trips, and
// file-level errors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/sim/io/io_test_util.h"
#include "tests/support/test_support.h"

namespace ld::io {
namespace {

using ::testing::HasSubstr;

struct Expected {
  const char* file;
  std::size_t vertices, triangles, boundaryEdges, nonManifoldEdges, components;
  bool closed;
  long euler;
  std::size_t degenerate;
};

// Counts from shared/data/SOURCES.md. Where our processing changes a count the
// comment says why (also in sim/io/README.md).
const Expected kShared[] = {
    // Binary STL: 1500 corners welded to 252 vertices.
    {"meshes/lapgym_glt_gallbladder_collision.stl", 252, 500, 0, 0, 1, true, 2, 0},
    // "open (bnd 31, nonman 2, 16 comp, 1 degenerate)".
    {"meshes/lapgym_glt_liver_collision.stl", 279, 479, 31, 2, 16, false, 26, 1},
    {"meshes/lapgym_tr_tissue_surface.obj", 448, 892, 0, 0, 1, true, 2, 0},
    // 50 nodes, 72 triangles from `2d_element` (no `face` element).
    {"meshes/opensurgsim_MassSpring2D.ply", 50, 72, 26, 0, 1, false, 1, 0},
    // 391 vertices in the file, only the 226 surface ones are used by faces: 165 dropped.
    {"meshes/opensurgsim_wound_deformable.ply", 226, 407, 41, 0, 2, false, 2, 0},
    {"meshes/sofa_liver-smooth.obj", 2194, 4384, 0, 0, 1, true, 2, 0},
    // V=181 in the file, 42 never referenced: dropped.
    {"meshes/sofa_liver.obj", 139, 274, 0, 0, 1, true, 2, 0},
    {"meshes/sofa_triangleGrid_10_10.obj", 100, 162, 36, 0, 1, false, 1, 0},
    // 8 Shapes, each with its own coordinates (not welded by default): open pieces.
    {"vrml/choreonoid_Labo1_valvehandle213.wrl", 258, 332, 204, 0, 8, false, -10, 2},
    {"vrml/choreonoid_PA10_J2_noheader.wrl", 52, 96, 0, 0, 2, true, 4, 0},
    {"vrml/coin_vrml1_coordinate3.wrl", 4, 2, 4, 0, 1, false, 1, 0},
    // Instancing: 28 USEs of an 8-point IFS (1 quad + 4 triangles = 6 triangles), each
    // under its own Translation, so every instance has its own 8 vertices.
    {"vrml/coin_vrml1_indexedfaceset.wrl", 28 * 8, 28 * 6, 28 * 8, 0, 28, false, 28, 0},
    // 23 USEs of 8 points and 3 quads.
    {"vrml/coin_vrml1_shapehints.wrl", 23 * 8, 23 * 6, 23 * 8, 0, 23, false, 23, 0},
    // 117 coordinates with duplicated seam vertices: open until welded (below).
    {"vrml/quesa_logo.wrl", 117, 192, 40, 0, 1, false, 1, 0},
    // 31 IFS, 486 triangles; some parts carry edges with more than two faces.
    {"vrml/vtk_bot2.wrl", 337, 486, 94, 4, 31, false, 51, 0},
    // 1290 polygons {3:215, 4:1070, 5:3, 6:1, 12:1} -> 215 + 2140 + 9 + 4 + 10 triangles;
    // closed genus 1 and still manifold (no fan diagonal reused).
    {"vrml/vtk_teapot.wrl", 1189, 2378, 0, 0, 1, true, 0, 0},
};

class SharedData : public ::testing::TestWithParam<Expected> {};

TEST_P(SharedData, CountsMatchSources) {
  const Expected& x = GetParam();
  LD_REQUIRE_SHARED_DATA(path, x.file);
  ImportReport rep;
  const auto soup = readSoup(path, {}, &rep);
  const auto st = computeStats(soup);
  EXPECT_EQ(st.vertices, x.vertices);
  EXPECT_EQ(st.triangles, x.triangles);
  EXPECT_EQ(st.boundaryEdges, x.boundaryEdges);
  EXPECT_EQ(st.nonManifoldEdges, x.nonManifoldEdges);
  EXPECT_EQ(st.components, x.components);
  EXPECT_EQ(st.closed, x.closed);
  EXPECT_EQ(st.euler, x.euler);
  EXPECT_EQ(st.degenerateFaces, x.degenerate);
  EXPECT_TRUE(st.consistentlyOriented);
  if (st.closed) {
    EXPECT_GT(test::signedVolume(soup), 0);
  }

  // The mesh holds the same surface (zero-area faces left out, non-manifold faces on
  // copied vertices) and passes its own invariant checks.
  ImportReport mrep;
  const auto m = readMesh(path, &mrep);
  EXPECT_TRUE(m.validate().ok()) << m.validate().message();
  EXPECT_EQ(m.nFaces(), x.triangles - x.degenerate);
  EXPECT_EQ(m.nVertices(), x.vertices + mrep.duplicatedVertices);
  EXPECT_EQ(mrep.duplicatedVertices > 0, x.nonManifoldEdges > 0);
}

std::string sharedName(const ::testing::TestParamInfo<Expected>& p) {
  std::string n = p.param.file;
  n = n.substr(n.find('/') + 1);
  for (char& c : n)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return n;
}

INSTANTIATE_TEST_SUITE_P(Io, SharedData, ::testing::ValuesIn(kShared), sharedName);

TEST(SharedDataWelded, ValvehandleAndQuesaCloseWhenWelded) {
  LD_REQUIRE_SHARED_DATA(valve, "vrml/choreonoid_Labo1_valvehandle213.wrl");
  LD_REQUIRE_SHARED_DATA(quesa, "vrml/quesa_logo.wrl");
  // SOURCES.md: after welding exact duplicates closed, genus 6 (chi = -10).
  auto st = computeStats(readSoup(valve, ReadOptions{true}));
  EXPECT_TRUE(st.closed);
  EXPECT_EQ(st.euler, -10);
  EXPECT_EQ(st.components, 1u);
  EXPECT_EQ(st.vertices, 156u);
  // SOURCES.md: after welding a closed torus (chi = 0).
  st = computeStats(readSoup(quesa, ReadOptions{true}));
  EXPECT_TRUE(st.closed);
  EXPECT_TRUE(st.manifold);
  EXPECT_EQ(st.euler, 0);
  EXPECT_EQ(st.vertices, 96u);
}

TEST(SharedDataDetails, HeaderlessFileWarnsAndSwitchHidesDefinitions) {
  LD_REQUIRE_SHARED_DATA(j2, "vrml/choreonoid_PA10_J2_noheader.wrl");
  ImportReport rep;
  readSoup(j2, {}, &rep);
  ASSERT_FALSE(rep.warnings.empty());
  EXPECT_THAT(rep.warnings[0], HasSubstr("choreonoid_PA10_J2_noheader.wrl:1: no '#VRML"));
  LD_REQUIRE_SHARED_DATA(quesa, "vrml/quesa_logo.wrl");
  ImportReport q;
  readSoup(quesa, {}, &q);
  std::string all;
  for (const auto& w : q.warnings) all += w + "\n";
  EXPECT_THAT(all, HasSubstr("Sphere"));
  EXPECT_THAT(all, HasSubstr("Cone"));
}

// ---- round trips -------------------------------------------------------------------

mesh::SurfaceMesh openBox() {
  // A unit cube without its top: open, so orientation is not rewritten on reading.
  mesh::SurfaceMesh m;
  std::vector<mesh::Vertex> v;
  for (int i = 0; i < 8; ++i)
    v.push_back(m.addVertex({0.1 * (i & 1) + 1e-17, 0.3 * ((i >> 1) & 1), 1.0 * ((i >> 2) & 1)}));
  const int f[10][3] = {{0, 2, 1}, {1, 2, 3}, {0, 1, 5}, {0, 5, 4}, {1, 3, 7},
                        {1, 7, 5}, {3, 2, 6}, {3, 6, 7}, {2, 0, 4}, {2, 4, 6}};
  for (const auto& t : f) EXPECT_TRUE(m.addFace(v[t[0]], v[t[1]], v[t[2]]).isValid());
  return m;
}

void expectSameMesh(const mesh::SurfaceMesh& a, const mesh::SurfaceMesh& b) {
  ASSERT_EQ(a.nVertices(), b.nVertices());
  ASSERT_EQ(a.nFaces(), b.nFaces());
  for (std::size_t i = 0; i < a.nVertices(); ++i)
    EXPECT_EQ(a.position(mesh::Vertex(i)), b.position(mesh::Vertex(i))) << "vertex " << i;  // bit-exact
  for (std::size_t i = 0; i < a.nFaces(); ++i) {
    const auto& fa = a.vertices(mesh::Face(i));
    const auto& fb = b.vertices(mesh::Face(i));
    // Same corners in the same cyclic order (orientation kept).
    bool same = false;
    for (int r = 0; r < 3; ++r)
      same = same || (fa[0] == fb[static_cast<std::size_t>(r)] && fa[1] == fb[static_cast<std::size_t>((r + 1) % 3)] &&
                      fa[2] == fb[static_cast<std::size_t>((r + 2) % 3)]);
    EXPECT_TRUE(same) << "face " << i;
  }
  EXPECT_TRUE(b.validate().ok());
}

class RoundTrip : public ::testing::TestWithParam<const char*> {};

TEST_P(RoundTrip, KeepsCountsPositionsAndOrientation) {
  test::TempDir dir;
  const auto m = openBox();
  const auto file = dir.path() / (std::string("box") + GetParam());
  writeMesh(m, file);
  ImportReport rep;
  const auto back = readMesh(file, &rep);
  EXPECT_EQ(rep.flippedFaces, 0u);
  EXPECT_TRUE(rep.warnings.empty());
  expectSameMesh(m, back);
}

TEST_P(RoundTrip, SharedTeapotSurvivesTwoTrips) {
  LD_REQUIRE_SHARED_DATA(teapot, "vrml/vtk_teapot.wrl");
  test::TempDir dir;
  const auto m = readMesh(teapot);
  const auto f1 = dir.path() / (std::string("a") + GetParam());
  writeMesh(m, f1);
  const auto m1 = readMesh(f1);
  expectSameMesh(m, m1);
  const auto st = computeStats(readSoup(f1));
  EXPECT_TRUE(st.closed);
  EXPECT_EQ(st.euler, 0);
}

std::string extName(const ::testing::TestParamInfo<const char*>& p) { return std::string(p.param + 1); }

INSTANTIATE_TEST_SUITE_P(Io, RoundTrip, ::testing::Values(".obj", ".ply", ".wrl"), extName);

TEST(WriteMesh, BinaryPlyRoundTrip) {
  test::TempDir dir;
  const auto m = openBox();
  const auto file = dir.path() / "box.ply";
  writeMesh(m, file, WriteOptions{true});
  EXPECT_NE(readFileBytes(file).find("format binary_little_endian"), std::string::npos);
  expectSameMesh(m, readMesh(file));
}

TEST(WriteMesh, SkipsDeletedElements) {
  auto m = openBox();
  m.deleteFace(mesh::Face(0));
  m.deleteVertex(mesh::Vertex(6));
  test::TempDir dir;
  writeMesh(m, dir.path() / "cut.obj");
  const auto back = readMesh(dir.path() / "cut.obj");
  EXPECT_EQ(back.nFaces(), m.nFaces());
  EXPECT_TRUE(back.validate().ok());
}

TEST(WriteMesh, Failures) {
  const auto m = openBox();
  test::TempDir dir;
  EXPECT_THROW(writeMesh(m, dir.path() / "x.stl"), IoError);
  EXPECT_THROW(writeMesh(m, dir.path() / "missing" / "x.obj"), IoError);
}

TEST(ReadMesh, FileLevelErrors) {
  test::TempDir dir;
  EXPECT_THROW(readMesh(dir.path() / "nope.obj"), IoError);
  EXPECT_THROW(readMesh(dir.path()), ParseError);  // no known extension
  const auto txt = dir.write("model.txt", "v 0 0 0\n");
  EXPECT_THAT(test::parseErrorOf([&] { readMesh(txt); }), HasSubstr("model.txt:0: unknown model format '.txt'"));
  const auto bad = dir.write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
  try {
    readMesh(bad);
    ADD_FAILURE() << "no error";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.file(), bad.string());
    EXPECT_EQ(e.line(), 4);
  }
  // Upper-case extensions work.
  const auto up = dir.write("T.OFF", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(readMesh(up).nFaces(), 1u);
}

TEST(ReadMesh, EmptyModelGivesEmptyMesh) {
  test::TempDir dir;
  const auto f = dir.write("empty.wrl", "#VRML V2.0 utf8\n");
  const auto m = readMesh(f);
  EXPECT_TRUE(m.isEmpty());
  const auto st = computeStats(readSoup(f));
  EXPECT_EQ(st.triangles, 0u);
  EXPECT_FALSE(st.closed);
}

}  // namespace
}  // namespace ld::io
