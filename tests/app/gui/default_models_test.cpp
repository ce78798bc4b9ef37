// The bundled models in resources/models: valid closed manifolds as the design asks,
// and exactly what tools/models/generate_models produces (so they are not stale).
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "sim/mesh/surface_mesh.h"
#include "tests/support/test_support.h"
#include "tools/models/model_shapes.h"

namespace {

using ld::models::TriMesh;

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TriMesh readObj(const std::filesystem::path& p) {
  TriMesh m;
  std::istringstream in(slurp(p));
  std::string tag;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    if (!(ls >> tag)) continue;
    if (tag == "v") {
      ld::models::Vec3 v{};
      ls >> v[0] >> v[1] >> v[2];
      m.points.push_back(v);
    } else if (tag == "f") {
      ld::models::Tri t{};
      ls >> t[0] >> t[1] >> t[2];
      for (auto& i : t) --i;
      m.triangles.push_back(t);
    }
  }
  return m;
}

// The numbers inside `keyword [ ... ]` of a VRML file.
std::vector<double> vrmlArray(const std::string& text, const std::string& keyword) {
  const auto at = text.find(keyword);
  if (at == std::string::npos) return {};
  const auto open = text.find('[', at), close = text.find(']', at);
  std::string body = text.substr(open + 1, close - open - 1);
  for (auto& c : body)
    if (c == ',') c = ' ';
  std::istringstream in(body);
  std::vector<double> out;
  double x = 0;
  while (in >> x) out.push_back(x);
  return out;
}

ld::mesh::SurfaceMesh toSurfaceMesh(const TriMesh& t) {
  ld::mesh::SurfaceMesh m;
  std::vector<ld::mesh::Vertex> v;
  for (const auto& p : t.points) v.push_back(m.addVertex(ld::mesh::Point(p[0], p[1], p[2])));
  for (const auto& f : t.triangles) EXPECT_TRUE(m.addFace(v[f[0]], v[f[1]], v[f[2]]).isValid());
  return m;
}

class DefaultModel : public ::testing::TestWithParam<std::size_t> {};

TEST_P(DefaultModel, MatchesTheGeneratorAndIsAValidClosedSurface) {
  const auto spec = ld::models::defaultModels().at(GetParam());
  const auto file = ld::test::resourcesDir() / "models" / (spec.name + ".obj");
  ASSERT_TRUE(std::filesystem::exists(file)) << file;
  const TriMesh committed = readObj(file);
  const TriMesh generated = spec.make();
  ASSERT_EQ(committed.points.size(), generated.points.size()) << "rerun tools/models/generate.sh";
  ASSERT_EQ(committed.triangles, generated.triangles) << "rerun tools/models/generate.sh";
  for (std::size_t i = 0; i < committed.points.size(); ++i)
    for (std::size_t a = 0; a < 3; ++a)
      ASSERT_NEAR(committed.points[i][a], generated.points[i][a], 1e-5) << spec.name << " v" << i;

  const auto c = ld::models::check(committed);
  EXPECT_TRUE(c.problem.empty()) << c.problem;
  EXPECT_TRUE(c.closed && c.manifold && c.outward);
  EXPECT_EQ(c.components, 1);
  EXPECT_GT(c.minAngleDeg, 20.0) << "no slivers";

  const auto m = toSurfaceMesh(committed);
  EXPECT_TRUE(m.validate().ok()) << m.validate().message();
  EXPECT_TRUE(m.isClosed());
  EXPECT_EQ(m.connectedComponents().count, 1);
  EXPECT_EQ(m.nVertices() - m.nEdges() + m.nFaces(), 2u) << "a sphere-like surface (Euler characteristic 2)";
  // Centred at the origin.
  const auto b = m.bounds();
  EXPECT_TRUE(ld::test::nearVec(b.center(), Eigen::Vector3d::Zero(), 1e-3));
}

INSTANTIATE_TEST_SUITE_P(Models, DefaultModel, ::testing::Range<std::size_t>(0, ld::models::defaultModels().size()),
                         [](const ::testing::TestParamInfo<std::size_t>& p) {
                           return ld::models::defaultModels()[p.param].name;
                         });

TEST(TissueSlab, SizeResolutionAndTopFaceAsOthersRelyOn) {
  const auto m = toSurfaceMesh(readObj(ld::test::resourcesDir() / "models" / "tissue_slab.obj"));
  const auto b = m.bounds();
  EXPECT_TRUE(ld::test::nearVec(b.min, Eigen::Vector3d(-40, -30, -2.5), 1e-9));
  EXPECT_TRUE(ld::test::nearVec(b.max, Eigen::Vector3d(40, 30, 2.5), 1e-9));
  EXPECT_GT(m.nFaces(), 9000u);
  EXPECT_LT(m.nFaces(), 11000u);
  // Top faces face +z and cover 80 x 60 mm.
  double topArea = 0;
  for (auto f : m.faces()) {
    const auto n = m.faceNormal(f);
    if (m.centroid(f).z() > 2.4999) {
      EXPECT_GT(n.z(), 0.999);
      topArea += m.faceArea(f);
    }
  }
  EXPECT_TRUE(ld::test::near(topArea, 80.0 * 60.0, 1e-6));
  EXPECT_TRUE(ld::test::near(m.area(), 2 * 80 * 60 + 2 * 80 * 5 + 2 * 60 * 5, 1e-6));
}

TEST(TissueSlab, VrmlCopiesHoldTheSameMesh) {
  const auto dir = ld::test::resourcesDir() / "models";
  const TriMesh obj = readObj(dir / "tissue_slab.obj");
  for (const char* name : {"tissue_slab_v1.wrl", "tissue_slab_v2.wrl"}) {
    const std::string text = slurp(dir / name);
    EXPECT_EQ(text.rfind(std::string(name).find("v1") != std::string::npos ? "#VRML V1.0 ascii" : "#VRML V2.0 utf8", 0),
              0u)
        << name;
    const auto pts = vrmlArray(text, "point");
    const auto idx = vrmlArray(text, "coordIndex");
    ASSERT_EQ(pts.size(), 3 * obj.points.size()) << name;
    ASSERT_EQ(idx.size(), 4 * obj.triangles.size()) << name;
    for (std::size_t i = 0; i < obj.points.size(); ++i)
      for (std::size_t a = 0; a < 3; ++a) ASSERT_EQ(pts[3 * i + a], obj.points[i][a]) << name;
    for (std::size_t f = 0; f < obj.triangles.size(); ++f) {
      for (std::size_t k = 0; k < 3; ++k) ASSERT_EQ(idx[4 * f + k], obj.triangles[f][k]) << name;
      ASSERT_EQ(idx[4 * f + 3], -1.0) << name;
    }
  }
}

TEST(Generator, CheckCatchesBrokenMeshes) {
  TriMesh slab = ld::models::makeSlab(2, 2, 2, 2, 2, 2);
  EXPECT_TRUE(ld::models::check(slab).problem.empty());
  TriMesh open = slab;
  open.triangles.pop_back();
  EXPECT_FALSE(ld::models::check(open).closed);
  TriMesh flipped = slab;
  for (auto& t : flipped.triangles) std::swap(t[1], t[2]);
  EXPECT_FALSE(ld::models::check(flipped).outward);
  TriMesh twoFlipped = slab;
  std::swap(twoFlipped.triangles[0][1], twoFlipped.triangles[0][2]);
  EXPECT_FALSE(ld::models::check(twoFlipped).problem.empty());
}

}  // namespace
