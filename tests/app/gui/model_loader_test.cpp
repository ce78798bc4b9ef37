#include "app/gui/model_loader.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <unistd.h>

#include "tests/support/test_support.h"

namespace {

using ld::gui::ModelLoadError;
using ld::gui::readObjForDisplay;

std::filesystem::path writeTemp(const std::string& name, const std::string& text) {
  const auto p = std::filesystem::temp_directory_path() / ("ld_gui_" + std::to_string(::getpid()) + "_" + name);
  std::ofstream(p) << text;
  return p;
}

TEST(ObjForDisplay, FansPolygonsAndResolvesRelativeIndices) {
  const auto p = writeTemp(
      "quad.obj", "# comment\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\nf -4 -2 -1\n");
  const auto m = readObjForDisplay(p);
  ASSERT_EQ(m.positions.size(), 4u);
  ASSERT_EQ(m.triangles.size(), 3u);
  EXPECT_EQ(m.triangles[0], (ld::gui::Triangle{0, 1, 2}));
  EXPECT_EQ(m.triangles[1], (ld::gui::Triangle{0, 2, 3}));
  EXPECT_EQ(m.triangles[2], (ld::gui::Triangle{0, 2, 3}));
  std::filesystem::remove(p);
}

TEST(ObjForDisplay, ErrorsNameFileAndLine) {
  const auto p = writeTemp("bad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 7\n");
  try {
    readObjForDisplay(p);
    FAIL() << "out-of-range index accepted";
  } catch (const ModelLoadError& e) {
    EXPECT_NE(std::string(e.what()).find(p.string() + ":4: "), std::string::npos) << e.what();
  }
  const auto q = writeTemp("nan.obj", "v 0 0 0\nv nan 0 0\n");
  EXPECT_THROW(readObjForDisplay(q), ModelLoadError);
  const auto r = writeTemp("empty.obj", "v 0 0 0\n");
  EXPECT_THROW(readObjForDisplay(r), ModelLoadError);
  std::filesystem::remove(p);
  std::filesystem::remove(q);
  std::filesystem::remove(r);
}

TEST(LoadModel, MissingFileIsAnErrorNamingIt) {
  try {
    ld::gui::loadModel("/nonexistent/tissue.obj");
    FAIL();
  } catch (const ModelLoadError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("/nonexistent/tissue.obj:", 0), 0u) << e.what();
  }
}

TEST(LoadModel, ReadsTheDefaultTissue) {
  const auto m = ld::gui::loadModel(ld::test::resourcesDir() / "models" / "tissue_slab.obj");
  EXPECT_EQ(m.mesh.positions.size(), 5074u);
  EXPECT_EQ(m.mesh.triangles.size(), 10144u);
  const auto b = m.mesh.bounds();
  EXPECT_TRUE(ld::test::near(b.min[0], -40.0, 1e-4));
  EXPECT_TRUE(ld::test::near(b.max[2], 2.5, 1e-4));
}

}  // namespace
