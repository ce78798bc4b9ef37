// lapdissect-cli cut: the real binary on a small box and a trajectory written here (and on one
// bundled task, scripted).
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/data_paths.h"
#include "tests/support/run_command.h"

namespace {

namespace fs = std::filesystem;
using ld::test::runCommand;
using ld::test::shellQuote;

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() / ("ld_cut_cli_" + std::to_string(::getpid()) + "_" + std::to_string(std::rand()));
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

// Closed box [0,10]x[0,10]x[0,2] as OBJ, one quad per unit cell on top and bottom.
void writeBox(const fs::path& file) {
  std::ofstream o(file);
  int nx = 10, ny = 10;
  auto id = [&](int i, int j, int k) { return 1 + k * (nx + 1) * (ny + 1) + j * (nx + 1) + i; };
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) o << "v " << i << " " << j << " " << 2 * k << "\n";
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      o << "f " << id(i, j, 1) << " " << id(i + 1, j, 1) << " " << id(i + 1, j + 1, 1) << " " << id(i, j + 1, 1)
        << "\n";
      o << "f " << id(i, j, 0) << " " << id(i, j + 1, 0) << " " << id(i + 1, j + 1, 0) << " " << id(i + 1, j, 0)
        << "\n";
    }
  for (int i = 0; i < nx; ++i) {
    o << "f " << id(i, 0, 0) << " " << id(i + 1, 0, 0) << " " << id(i + 1, 0, 1) << " " << id(i, 0, 1) << "\n";
    o << "f " << id(i, ny, 0) << " " << id(i, ny, 1) << " " << id(i + 1, ny, 1) << " " << id(i + 1, ny, 0) << "\n";
  }
  for (int j = 0; j < ny; ++j) {
    o << "f " << id(0, j, 0) << " " << id(0, j, 1) << " " << id(0, j + 1, 1) << " " << id(0, j + 1, 0) << "\n";
    o << "f " << id(nx, j, 0) << " " << id(nx, j + 1, 0) << " " << id(nx, j + 1, 1) << " " << id(nx, j, 1) << "\n";
  }
}

// Scalpel, blade vertical, tip at height z, sliding along x from x0 to x1 at y.
void writeStroke(const fs::path& file, double x0, double x1, double y, double z, int n) {
  std::ofstream o(file);
  o << "t,hand,tool,tip_x,tip_y,tip_z,dir_x,dir_y,dir_z,up_x,up_y,up_z,jaw,pedal\n";
  for (int i = 0; i <= n; ++i)
    o << i * 0.001 << ",right,scalpel," << x0 + (x1 - x0) * i / n << "," << y << "," << z << ",0,0,-1,1,0,0,0,0\n";
}

nlohmann::json run(const std::string& args, int expectCode = 0) {
  const auto r = runCommand(std::string(LD_CLI) + " " + args);
  EXPECT_EQ(r.exitCode, expectCode) << r.err;
  if (expectCode != 0) return nlohmann::json{{"stderr", r.err}};
  return nlohmann::json::parse(r.out);
}

TEST(CutCli, CutThroughWritesTwoClosedPieces) {
  TempDir d;
  writeBox(d.path / "box.obj");
  writeStroke(d.path / "through.csv", -1, 11, 5.3, -1, 600);
  const auto out = d.path / "pieces.obj";
  const auto j = run("cut --mesh " + shellQuote((d.path / "box.obj").string()) + " --trajectory " +
                     shellQuote((d.path / "through.csv").string()) + " --out " + shellQuote(out.string()));
  for (const char* k : {"triangles_cut", "triangles_added", "vertices_added", "components", "manifold", "closed",
                        "min_triangle_area", "remesh_us_per_cut_triangle", "nan"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_EQ(j["components"], 2);
  EXPECT_EQ(j["manifold"], true);
  EXPECT_EQ(j["closed"], true);
  EXPECT_EQ(j["nan"], false);
  EXPECT_GT(j["triangles_cut"].get<long>(), 10);
  EXPECT_GT(j["triangles_added"].get<long>(), 0);
  EXPECT_GT(j["min_triangle_area"].get<double>(), 0.0);
  // `mesh info` checks the written pieces.
  const auto info = run("mesh info " + shellQuote(out.string()));
  EXPECT_EQ(info["components"], 2);
  EXPECT_EQ(info["closed"], true);
  EXPECT_EQ(info["manifold"], true);
  EXPECT_NEAR(info["area"].get<double>(), 280.0 + 40.0, 1e-6);
}

TEST(CutCli, ShallowStrokeIsOneClosedPieceAndDeterministic) {
  TempDir d;
  writeBox(d.path / "box.obj");
  writeStroke(d.path / "groove.csv", 2, 8, 5.3, 1.0, 300);
  const std::string cmd = "cut --mesh " + shellQuote((d.path / "box.obj").string()) + " --trajectory " +
                          shellQuote((d.path / "groove.csv").string()) + " --physics off";
  const auto a = run(cmd), b = run(cmd);
  EXPECT_EQ(a["components"], 1);
  EXPECT_EQ(a["closed"], true);
  EXPECT_EQ(a["triangles_added"], b["triangles_added"]);
  EXPECT_EQ(a["vertices_added"], b["vertices_added"]);
  for (const char* k : {"bottom_slides", "flips", "sliver_snaps", "holds"}) {
    ASSERT_TRUE(a.contains(k)) << k;
    EXPECT_GE(a[k].get<long>(), 0) << k;
    EXPECT_EQ(a[k], b[k]) << k;
  }
  EXPECT_EQ(a["holds"], 0) << "still tissue never runs ahead of the blade";
  // The groove follows the blade all the way: no failure, so none listed by its end.
  EXPECT_EQ(a["walk_failures"], 0);
  ASSERT_TRUE(a["walk_failures_by"].is_object());
  EXPECT_TRUE(a["walk_failures_by"].empty()) << a["walk_failures_by"].dump();
  EXPECT_EQ(a["lip_stops"], 0);
}

// The bundled circle task traced at level 0: its groove comes round to where it began
// and closes into a ring there, physics off and on, with no walk failure (it used to
// stop 1.3 mm short, blocked next to its own start), and its start opens (no pinch).
// On the organ fold (physics on) the hook's two edges start beside each other and the
// second runs into the first one's groove 0.2 mm on: one track ended as run into an
// earlier cut (starts_merged), which used to be the run's one walk failure; the walk
// failures, if any, are listed by how the walk ended and add up.
TEST(CutCli, CircleTaskGrooveClosesOnItsStartAndFailuresAreListedByEnd) {
  const fs::path res = ld::test::resourcesDir();
  TempDir d;
  auto script = [&](const std::string& task) {
    const auto traj = d.path / (task + ".csv");
    const auto r = runCommand(std::string(LD_CLI) + " task script --task " +
                              shellQuote((res / "tasks" / (task + ".json")).string()) +
                              " --level 0 --rate 1000 --out " + shellQuote(traj.string()));
    EXPECT_EQ(r.exitCode, 0) << r.err;
    return traj;
  };
  const auto circle = script("slab-circle-cutout");
  for (const char* physics : {"off", "on"}) {
    SCOPED_TRACE(physics);
    const auto j = run("cut --mesh " + shellQuote((res / "models" / "tissue_slab.obj").string()) + " --trajectory " +
                       shellQuote(circle.string()) + " --physics " + physics);
    EXPECT_EQ(j["starts_closed"].get<long>(), 1);
    // Its start opens too, though the hook's foot cut a slit beside the groove there as
    // it went in (more than two edges between walls meet at the start).
    EXPECT_EQ(j["starts_opened"].get<long>(), 1);
    EXPECT_EQ(j["walk_failures"].get<long>(), 0) << j["walk_failures_by"].dump();
    EXPECT_EQ(j["objects"].get<long>(), 1) << "a groove frees nothing";
  }
  const auto fold = script("organ-fold");
  const auto j = run("cut --mesh " + shellQuote((res / "models" / "organ.obj").string()) + " --trajectory " +
                     shellQuote(fold.string()) + " --physics on");
  EXPECT_EQ(j["starts_merged"].get<long>(), 1);
  EXPECT_EQ(j["walk_failures"].get<long>(), 0) << j["walk_failures_by"].dump();
  EXPECT_EQ(j["objects"].get<long>(), 1);
  ASSERT_TRUE(j["walk_failures_by"].is_object());
  long sum = 0;
  for (const auto& [end, n] : j["walk_failures_by"].items()) {
    EXPECT_TRUE(end == "no_way" || end == "unreached" || end == "too_long" || end == "blocked" ||
                end == "not_adjacent" || end == "refused" || end == "at_earlier_wall")
        << end;
    EXPECT_GT(n.get<long>(), 0) << end;
    sum += n.get<long>();
  }
  EXPECT_EQ(sum, j["walk_failures"].get<long>());
  EXPECT_GE(j["lip_stops"].get<long>(), 0);
}

TEST(CutCli, PhysicsOnRunsAndStaysFinite) {
  TempDir d;
  writeBox(d.path / "box.obj");
  writeStroke(d.path / "groove.csv", 2, 8, 5.3, 1.0, 100);
  const auto j = run("cut --mesh " + shellQuote((d.path / "box.obj").string()) + " --trajectory " +
                     shellQuote((d.path / "groove.csv").string()) + " --physics on");
  EXPECT_EQ(j["nan"], false);
  EXPECT_EQ(j["components"], 1);
  // Steps of at most 1 ms, each stable at once: the mass floor keeps the short, stiff
  // edges of the cut from needing the monitor's retries.
  EXPECT_GE(j["physics_steps"].get<long>(), 99);
  EXPECT_EQ(j["physics_rejected_steps"], 0);
  EXPECT_EQ(j["physics_implicit_fallbacks"], 0);
}

// Physics moves every vertex: one full collision refit per step, none local. With the
// active region the engine is told only the awake vertices (all of them for a while
// after each cut edit, which wakes the whole tissue), nothing once it sleeps.
TEST(CutCli, PhysicsTellsTheCutterWhatMoved) {
  TempDir d;
  writeBox(d.path / "box.obj");
  writeStroke(d.path / "groove.csv", 2, 8, 5.3, 1.0, 400);
  {
    // Then one second with the blade lifted: the tissue settles and falls asleep.
    std::ofstream o(d.path / "groove.csv", std::ios::app);
    for (int i = 1; i <= 1000; ++i) o << (400 + i) * 0.001 << ",right,scalpel,8,5.3,10,0,0,-1,1,0,0,0,0\n";
  }
  const std::string base = "cut --mesh " + shellQuote((d.path / "box.obj").string()) + " --trajectory " +
                           shellQuote((d.path / "groove.csv").string()) + " --physics on";
  const auto full = run(base + " --collision-margin 0");
  EXPECT_GT(full["collision_full_refits"].get<long>(), 100);
  EXPECT_EQ(full["collision_region_refits"], 0);
  // By default fat collision boxes: no full refit, and the same cut.
  const auto fat = run(base);
  EXPECT_GT(fat["collision_margin"].get<double>(), 0.0);
  EXPECT_EQ(fat["collision_full_refits"], 0);
  EXPECT_GT(fat["collision_margin_refits"].get<long>(), 100);
  for (const char* key : {"triangles_cut", "triangles_added", "vertices_added", "min_triangle_area", "closed"})
    EXPECT_EQ(fat[key], full[key]) << key;
  const auto region = run(base + " --active-region on");
  EXPECT_EQ(region["active_region"], "on");
  EXPECT_EQ(region["nan"], false);
  EXPECT_EQ(region["closed"], true);
  EXPECT_GT(region["collision_region_refits"].get<long>(), 0);
  EXPECT_LT(region["collision_full_refits"].get<long>(), full["collision_full_refits"].get<long>());
  EXPECT_GT(region["collision_vertices_refitted"].get<long>(), 0);
  // The steps that integrated a region: most of them, each a part of the box.
  const long steps = region["physics_steps"].get<long>(), regionSteps = region["physics_region_steps"].get<long>();
  EXPECT_GT(2 * regionSteps, steps);
  EXPECT_LE(regionSteps, steps);
  EXPECT_GT(region["physics_us_per_region_step"].get<double>(), 0.0);
  EXPECT_GT(region["physics_region_vertices_mean"].get<double>(), 0.0);
  EXPECT_FALSE(fat.contains("physics_region_steps")) << "only with the region on";
  run(base + " --active-region maybe", 2);
}

TEST(CutCli, BadInputExitsWithTwo) {
  TempDir d;
  writeBox(d.path / "box.obj");
  {
    std::ofstream o(d.path / "bad.csv");
    o << "t,hand,tool,tip_x,tip_y,tip_z,dir_x,dir_y,dir_z,up_x,up_y,up_z,jaw,pedal\n0,right,knife,0,0,0,0,0,-1,1,0,0,0,"
         "0\n";
  }
  const auto e = run("cut --mesh " + shellQuote((d.path / "box.obj").string()) + " --trajectory " +
                         shellQuote((d.path / "bad.csv").string()),
                     2);
  EXPECT_NE(e["stderr"].get<std::string>().find("bad.csv"), std::string::npos);
  run("cut --mesh " + shellQuote((d.path / "missing.obj").string()) + " --trajectory " +
          shellQuote((d.path / "bad.csv").string()),
      2);
  run("cut --mesh " + shellQuote((d.path / "box.obj").string()) + " --trajectory x.csv --physics maybe", 2);
}

}  // namespace
