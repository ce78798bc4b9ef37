// Every bundled task and curriculum file is valid, and the tasks' paths lie on their
// models' surfaces.
#include <filesystem>
#include <set>

#include "curriculum/curriculum_plan.h"
#include "curriculum/json_check.h"
#include "curriculum/task.h"
#include "curriculum/tissue_path.h"
#include "sim/io/mesh_io.h"
#include "tests/support/test_support.h"

namespace ld::curriculum {
namespace {

namespace fs = std::filesystem;

TEST(BundledTasks, AllValidWithRisingDifficulty) {
  const fs::path dir = test::resourcesDir() / "tasks";
  ASSERT_TRUE(fs::exists(dir)) << dir;
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() != ".json") continue;
    ++files;
    const auto errs = validateTask(readJsonFile(e.path().string()), e.path().string());
    EXPECT_TRUE(errs.empty()) << e.path() << ": " << (errs.empty() ? "" : errs.front());
  }
  EXPECT_GE(files, 5);
  const TaskLibrary lib = TaskLibrary::loadFolder(dir);
  for (const char* id :
       {"slab-straight-line", "slab-gentle-curve", "slab-s-curve", "slab-circle-cutout", "organ-curve", "organ-fold"})
    ASSERT_NE(lib.find(id), nullptr) << id;
  EXPECT_LT(lib.find("slab-straight-line")->level, lib.find("slab-gentle-curve")->level);
  EXPECT_LT(lib.find("slab-gentle-curve")->level, lib.find("slab-s-curve")->level);
  EXPECT_LT(lib.find("slab-s-curve")->level, lib.find("slab-circle-cutout")->level);
  EXPECT_LT(lib.find("slab-circle-cutout")->level, lib.find("organ-fold")->level);
  for (const auto& id : lib.ids()) {
    const Task* t = lib.find(id);
    EXPECT_TRUE(t->proficiency.maxDeviationMm2.has_value()) << id;
    EXPECT_TRUE(t->proficiency.minBandFraction.has_value()) << id;
    EXPECT_EQ(t->proficiency.consecutive, 2) << id;
  }
}

TEST(BundledTasks, PathsLieOnTheirModels) {
  const fs::path dir = test::resourcesDir() / "tasks";
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() != ".json") continue;
    const Task t = loadTask(e.path());
    const fs::path model = resolveModel(t, e.path());
    ASSERT_FALSE(model.empty()) << t.id << ": model " << t.model << " not found";
    const mesh::SurfaceMesh m = io::readMesh(model);
    ASSERT_GT(m.nFaces(), 0u);
    // Embedding succeeds (within 0.05 mm of the surface) ...
    const TissuePath tp = TissuePath::embed(m, t.path, 0.05);
    // ... and no point leaves the model's top side.
    const Polyline p = tp.positions(m);
    ASSERT_EQ(p.size(), t.path.size());
    for (std::size_t i = 0; i < p.size(); ++i)
      EXPECT_TRUE(test::nearVec(p[i].p, t.path[i].p, 0.05)) << t.id << " point " << i;
  }
}

TEST(BundledCurriculum, DefaultIsValidAndUsesEveryTask) {
  const TaskLibrary lib = TaskLibrary::loadFolder(test::resourcesDir() / "tasks");
  const fs::path file = test::resourcesDir() / "curriculum" / "default.json";
  const auto errs = validateCurriculum(readJsonFile(file.string()), file.string(), &lib);
  EXPECT_TRUE(errs.empty()) << (errs.empty() ? "" : errs.front());
  const Curriculum c = loadCurriculum(file, &lib);
  EXPECT_GE(c.modules.size(), 2u);
  std::set<std::string> used;
  for (const auto& m : c.modules)
    for (const auto& t : m.tasks) used.insert(t.task);
  for (const auto& id : lib.ids()) EXPECT_TRUE(used.count(id)) << id << " is in no module";
  EXPECT_EQ(progress(c, {}).nextTask, "slab-straight-line");
}

}  // namespace
}  // namespace ld::curriculum
