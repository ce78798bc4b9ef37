// lapdissect-cli mesh info / mesh convert on the real binary: every shared data file,
// bad files (exit 2, one line "file:line: reason" on stderr) and conversions.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/run_command.h"

namespace {

namespace fs = std::filesystem;
using ld::test::CommandResult;
using ld::test::runCommand;
using ld::test::shellQuote;

// Path of a file in ../shared/data, or empty when absent. (Not test_support.h: this
// target does not link Eigen.)
fs::path sharedData(const std::string& rel) {
  const char* env = std::getenv("LD_SHARED_DATA");
  const fs::path p = fs::path(env ? env : LD_SHARED_DATA_DIR) / rel;
  return fs::exists(p) ? p : fs::path();
}

CommandResult cli(const std::string& args) { return runCommand(shellQuote(LD_CLI) + " " + args); }

class MeshCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ld_meshcli_" + std::to_string(::getpid()) + "_" + std::to_string(std::rand()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path write(const std::string& name, const std::string& content) {
    std::ofstream(dir_ / name, std::ios::binary) << content;
    return dir_ / name;
  }
  fs::path dir_;
};

struct Row {
  const char* file;
  int vertices, triangles, edges, boundaryEdges, components;
  bool manifold, closed;
};

// SOURCES.md counts as `mesh info` reports them (see tests/sim/io/mesh_io_test.cpp and
// sim/io/README.md for where welding, instancing or dropping changes the file's numbers).
const Row kRows[] = {
    {"meshes/lapgym_glt_gallbladder_collision.stl", 252, 500, 750, 0, 1, true, true},
    {"meshes/lapgym_glt_liver_collision.stl", 279, 479, 732, 31, 16, false, false},
    {"meshes/lapgym_tr_tissue_surface.obj", 448, 892, 1338, 0, 1, true, true},
    {"meshes/opensurgsim_MassSpring2D.ply", 50, 72, 121, 26, 1, true, false},
    {"meshes/opensurgsim_wound_deformable.ply", 226, 407, 631, 41, 2, true, false},
    {"meshes/sofa_liver-smooth.obj", 2194, 4384, 6576, 0, 1, true, true},
    {"meshes/sofa_liver.obj", 139, 274, 411, 0, 1, true, true},
    {"meshes/sofa_triangleGrid_10_10.obj", 100, 162, 261, 36, 1, true, false},
    {"vrml/choreonoid_Labo1_valvehandle213.wrl", 258, 332, 600, 204, 8, true, false},
    {"vrml/choreonoid_PA10_J2_noheader.wrl", 52, 96, 144, 0, 2, true, true},
    {"vrml/coin_vrml1_coordinate3.wrl", 4, 2, 5, 4, 1, true, false},
    {"vrml/coin_vrml1_indexedfaceset.wrl", 224, 168, 364, 224, 28, true, false},
    {"vrml/coin_vrml1_shapehints.wrl", 184, 138, 299, 184, 23, true, false},
    {"vrml/quesa_logo.wrl", 117, 192, 308, 40, 1, true, false},
    {"vrml/vtk_bot2.wrl", 337, 486, 772, 94, 31, false, false},
    {"vrml/vtk_teapot.wrl", 1189, 2378, 3567, 0, 1, true, true},
};

TEST_F(MeshCli, InfoOnEverySharedFile) {
  if (sharedData("meshes").empty()) GTEST_SKIP() << "../shared/data is absent";
  for (const Row& r : kRows) {
    SCOPED_TRACE(r.file);
    const auto path = sharedData(r.file);
    ASSERT_FALSE(path.empty());
    const auto res = cli("mesh info " + shellQuote(path.string()));
    ASSERT_EQ(res.exitCode, 0) << res.err;
    const auto j = nlohmann::json::parse(res.out);
    for (const char* key :
         {"vertices", "triangles", "edges", "boundary_edges", "components", "manifold", "closed", "area", "bbox"})
      EXPECT_TRUE(j.contains(key)) << key;
    EXPECT_EQ(j["vertices"], r.vertices);
    EXPECT_EQ(j["triangles"], r.triangles);
    EXPECT_EQ(j["edges"], r.edges);
    EXPECT_EQ(j["boundary_edges"], r.boundaryEdges);
    EXPECT_EQ(j["components"], r.components);
    EXPECT_EQ(j["manifold"], r.manifold);
    EXPECT_EQ(j["closed"], r.closed);
    EXPECT_GT(j["area"].get<double>(), 0.0);
    ASSERT_EQ(j["bbox"].size(), 2u);
    for (int k = 0; k < 3; ++k) EXPECT_LE(j["bbox"][0][k].get<double>(), j["bbox"][1][k].get<double>());
  }
}

TEST_F(MeshCli, InfoDetails) {
  const auto grid = sharedData("meshes/sofa_triangleGrid_10_10.obj");
  if (grid.empty()) GTEST_SKIP() << "../shared/data is absent";
  auto j = nlohmann::json::parse(cli("mesh info " + shellQuote(grid.string())).out);
  EXPECT_EQ(j["bbox"], nlohmann::json::parse("[[0,0,0],[10,10,0]]"));
  EXPECT_DOUBLE_EQ(j["area"].get<double>(), 100.0);
  const auto teapot = sharedData("vrml/vtk_teapot.wrl");
  j = nlohmann::json::parse(cli("mesh info " + shellQuote(teapot.string())).out);
  EXPECT_EQ(j["genus"], 1);
  EXPECT_EQ(j["non_manifold_edges"], 0);
  const auto valve = sharedData("vrml/choreonoid_Labo1_valvehandle213.wrl");
  j = nlohmann::json::parse(cli("mesh info " + shellQuote(valve.string()) + " --weld on").out);
  EXPECT_EQ(j["closed"], true);
  EXPECT_EQ(j["genus"], 6);
  EXPECT_EQ(j["degenerate_faces"], 2);
  const auto j2 = sharedData("vrml/choreonoid_PA10_J2_noheader.wrl");
  j = nlohmann::json::parse(cli("mesh info " + shellQuote(j2.string())).out);
  ASSERT_FALSE(j["warnings"].empty());
  EXPECT_NE(j["warnings"][0].get<std::string>().find(":1: no '#VRML"), std::string::npos);
}

TEST_F(MeshCli, BadFilesExitTwoWithPlaceAndReason) {
  std::string stl(80, ' ');
  const std::uint32_t n = 3;  // announces 3 triangles, holds none
  stl.append(reinterpret_cast<const char*>(&n), 4);
  const std::pair<fs::path, std::string> cases[] = {
      {write("index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n"), "index.obj:4: face index '7' out of range"},
      {write("nan.obj", "v 0 0 0\nv nan 0 0\n"), "nan.obj:2: non-finite"},
      {write("braces.wrl", "#VRML V2.0 utf8\nGroup {\n children [\n Group { }\n"), "braces.wrl:3: unbalanced"},
      {write("close.wrl", "#VRML V1.0 ascii\nSeparator { }\n}\n"), "close.wrl:3: unbalanced braces"},
      {write("count.stl", stl), "count.stl:0: binary STL announces 3 triangles"},
      {write("trunc.ply",
             "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement "
             "face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n"),
       "trunc.ply:11: unexpected end of file in element 'vertex'"},
      {write("counts.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), "counts.off:6:"},
      {write(
           "range.wrl",
           "#VRML V2.0 utf8\nShape { geometry IndexedFaceSet { coord Coordinate { point [0 0 0] }\ncoordIndex [0 1 2] "
           "} }\n"),
       "range.wrl:3: coordIndex 1 out of range"},
      {write("model.xyz", "1 2 3\n"), "model.xyz:0: unknown model format"},
  };
  for (const auto& [file, expected] : cases) {
    SCOPED_TRACE(file.string());
    const auto res = cli("mesh info " + shellQuote(file.string()));
    EXPECT_EQ(res.exitCode, 2);
    EXPECT_TRUE(res.out.empty()) << res.out;
    EXPECT_NE(res.err.find(expected), std::string::npos) << res.err;
    EXPECT_EQ(res.err.find(file.string() + ":"), 0u) << res.err;  // starts with the file
    ASSERT_FALSE(res.err.empty());
    EXPECT_EQ(res.err.find('\n'), res.err.size() - 1) << "one line: " << res.err;
    // convert refuses the same files the same way.
    const auto conv = cli("mesh convert " + shellQuote(file.string()) + " " + shellQuote((dir_ / "o.obj").string()));
    EXPECT_EQ(conv.exitCode, 2);
    EXPECT_NE(conv.err.find(expected), std::string::npos) << conv.err;
  }
  const auto missing = cli("mesh info " + shellQuote((dir_ / "absent.obj").string()));
  EXPECT_EQ(missing.exitCode, 2);
  EXPECT_NE(missing.err.find("absent.obj"), std::string::npos);
  EXPECT_EQ(cli("mesh frobnicate x").exitCode, 2);
  EXPECT_EQ(cli("mesh info").exitCode, 2);
  EXPECT_EQ(cli("mesh info " + shellQuote(write("ok.off", "OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").string()) +
                " --weld maybe")
                .exitCode,
            2);
}

TEST_F(MeshCli, ConvertRoundTripsThroughEveryExportFormat) {
  const auto teapot = sharedData("vrml/vtk_teapot.wrl");
  if (teapot.empty()) GTEST_SKIP() << "../shared/data is absent";
  for (const char* ext : {".obj", ".ply", ".wrl"}) {
    SCOPED_TRACE(ext);
    const auto out = dir_ / (std::string("teapot") + ext);
    const auto res = cli("mesh convert " + shellQuote(teapot.string()) + " " + shellQuote(out.string()));
    ASSERT_EQ(res.exitCode, 0) << res.err;
    EXPECT_EQ(nlohmann::json::parse(res.out)["triangles"], 2378);
    const auto j = nlohmann::json::parse(cli("mesh info " + shellQuote(out.string())).out);
    EXPECT_EQ(j["vertices"], 1189);
    EXPECT_EQ(j["triangles"], 2378);
    EXPECT_EQ(j["closed"], true);
    EXPECT_EQ(j["flipped_faces"], 0);  // written outward, read back unchanged
  }
  const auto bin = dir_ / "teapot_bin.ply";
  ASSERT_EQ(
      cli("mesh convert " + shellQuote(teapot.string()) + " " + shellQuote(bin.string()) + " --binary on").exitCode, 0);
  const auto jb = nlohmann::json::parse(cli("mesh info " + shellQuote(bin.string())).out);
  EXPECT_EQ(jb["triangles"], 2378);
  EXPECT_EQ(jb["genus"], 1);
  const auto stl = cli("mesh convert " + shellQuote(teapot.string()) + " " + shellQuote((dir_ / "t.stl").string()));
  EXPECT_EQ(stl.exitCode, 2);
  const auto nodir =
      cli("mesh convert " + shellQuote(teapot.string()) + " " + shellQuote((dir_ / "no" / "t.obj").string()));
  EXPECT_EQ(nodir.exitCode, 2);
  EXPECT_NE(nodir.err.find("cannot open for writing"), std::string::npos);
}

// The default tissue's box at a chosen resolution: closed, one piece, outward, in
// tissue_slab.obj's frame, about as many triangles as asked for.
TEST_F(MeshCli, SlabHasTheDefaultTissuesBoxAtTheAskedResolution) {
  for (int wanted : {2000, 20000}) {
    SCOPED_TRACE(wanted);
    const auto out = dir_ / ("slab" + std::to_string(wanted) + ".obj");
    const auto res = cli("mesh slab --triangles " + std::to_string(wanted) + " --out " + shellQuote(out.string()));
    ASSERT_EQ(res.exitCode, 0) << res.err;
    const auto made = nlohmann::json::parse(res.out);
    const auto j = nlohmann::json::parse(cli("mesh info " + shellQuote(out.string())).out);
    EXPECT_EQ(j["triangles"], made["triangles"]);
    EXPECT_NEAR(j["triangles"].get<double>(), wanted, 0.1 * wanted);
    EXPECT_EQ(j["closed"], true);
    EXPECT_EQ(j["manifold"], true);
    EXPECT_EQ(j["components"], 1);
    EXPECT_EQ(j["consistently_oriented"], true);
    EXPECT_EQ(j["flipped_faces"], 0);
    EXPECT_NEAR(j["area"].get<double>(), 11000.0, 1e-6);
    const double box[2][3] = {{-40.0, -30.0, -2.5}, {40.0, 30.0, 2.5}};
    for (int c = 0; c < 2; ++c)
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(j["bbox"][c][k].get<double>(), box[c][k], 1e-9);
  }
  for (const std::string bad : {"--triangles 5", "--triangles many", "--triangles 1e9"}) {
    SCOPED_TRACE(bad);
    const auto res = cli("mesh slab " + bad + " --out " + shellQuote((dir_ / "bad.obj").string()));
    EXPECT_EQ(res.exitCode, 2);
    EXPECT_NE(res.err.find("--triangles"), std::string::npos) << res.err;
    EXPECT_FALSE(fs::exists(dir_ / "bad.obj"));
  }
  const auto stl = cli("mesh slab --triangles 1000 --out " + shellQuote((dir_ / "s.stl").string()));
  EXPECT_EQ(stl.exitCode, 2);
  EXPECT_NE(stl.err.find("s.stl"), std::string::npos) << stl.err;
}

}  // namespace
