// Runs `lapdissect --model FILE --screenshot OUT.png` and checks the picture: the right
// size, not blank, tissue-coloured (pink/red) pixels in the middle, background at the
// corners. Needs an X display (ctest runs under xvfb-run); skips without DISPLAY.
#include <QColor>
#include <QImage>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>

#include <unistd.h>

#include "tests/support/run_command.h"
#include "tests/support/test_support.h"

namespace {

using ld::test::runCommand;
using ld::test::shellQuote;

#define LD_REQUIRE_DISPLAY()                                                              \
  if (!std::getenv("DISPLAY") || !*std::getenv("DISPLAY"))                                \
  GTEST_SKIP() << "no X display (DISPLAY unset): run the GUI tests under xvfb-run, e.g. " \
                  "xvfb-run -a -s \"-screen 0 1920x1080x24\" ctest -L gui"

std::filesystem::path tempPng(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("ld_shot_" + std::to_string(::getpid()) + "_" + name + ".png");
}

bool isTissue(QRgb p) {
  const int r = qRed(p), g = qGreen(p), b = qBlue(p);
  return r > 90 && r > g + 35 && r > b + 30;
}

struct Shot {
  ld::test::CommandResult run;
  QImage image;
};

Shot screenshot(const std::filesystem::path& model, const std::string& name, const std::string& extra = "") {
  const auto out = tempPng(name);
  std::filesystem::remove(out);
  Shot s;
  s.run = runCommand(shellQuote(LD_GUI_BIN) + " --model " + shellQuote(model.string()) + " --screenshot " +
                     shellQuote(out.string()) + " --size 640x400 " + extra);
  s.image = QImage(QString::fromStdString(out.string()));
  std::filesystem::remove(out);
  return s;
}

// Fraction of tissue pixels in the central box of `frac` of the width and height.
double tissueFractionInMiddle(const QImage& img, double frac) {
  const int w = img.width(), h = img.height();
  const int x0 = static_cast<int>(w * (0.5 - frac / 2)), x1 = static_cast<int>(w * (0.5 + frac / 2));
  const int y0 = static_cast<int>(h * (0.5 - frac / 2)), y1 = static_cast<int>(h * (0.5 + frac / 2));
  int tissue = 0, all = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x, ++all) tissue += isTissue(img.pixel(x, y)) ? 1 : 0;
  return all ? static_cast<double>(tissue) / all : 0.0;
}

void expectShowsTissue(const Shot& s, double minMiddleFraction) {
  ASSERT_EQ(s.run.exitCode, 0) << s.run.err;
  ASSERT_FALSE(s.image.isNull()) << "no PNG written";
  EXPECT_EQ(s.image.width(), 640);
  EXPECT_EQ(s.image.height(), 400);
  // Not blank: many distinct colours (shading), and not one colour everywhere.
  std::set<QRgb> colours;
  for (int y = 0; y < s.image.height(); y += 4)
    for (int x = 0; x < s.image.width(); x += 4) colours.insert(s.image.pixel(x, y));
  EXPECT_GT(colours.size(), 50u) << "the picture looks blank or flat";
  EXPECT_GE(tissueFractionInMiddle(s.image, 0.2), minMiddleFraction) << "no tissue in the middle of the picture";
  // The model is fitted and centred: the corners show the background.
  for (const auto& [x, y] : {std::pair{2, 2}, {637, 2}, {2, 397}, {637, 397}})
    EXPECT_FALSE(isTissue(s.image.pixel(x, y))) << "corner " << x << "," << y;
}

TEST(GuiScreenshot, DefaultTissueSlab) {
  LD_REQUIRE_DISPLAY();
  const Shot s = screenshot(ld::test::resourcesDir() / "models" / "tissue_slab.obj", "slab");
  expectShowsTissue(s, 0.95);
  // The slab is lit: its top face is not one flat colour (Phong shading with a
  // positional light gives a gradient).
  const QColor a = s.image.pixelColor(200, 200), b = s.image.pixelColor(440, 200);
  EXPECT_NE(a.rgb(), b.rgb());
}

TEST(GuiScreenshot, WireframeOverlayDrawsEdges) {
  LD_REQUIRE_DISPLAY();
  const auto slab = ld::test::resourcesDir() / "models" / "tissue_slab.obj";
  const Shot solid = screenshot(slab, "solid");
  const Shot wire = screenshot(slab, "wire", "--wireframe");
  ASSERT_EQ(wire.run.exitCode, 0) << wire.run.err;
  ASSERT_FALSE(wire.image.isNull());
  // Dark edge lines replace some tissue pixels in the middle.
  const double fs = tissueFractionInMiddle(solid.image, 0.2), fw = tissueFractionInMiddle(wire.image, 0.2);
  EXPECT_LT(fw, fs - 0.1) << "solid " << fs << " wireframe " << fw;
  EXPECT_GT(fw, 0.2) << "the surface is still drawn under the wireframe";
}

TEST(GuiScreenshot, OrganModel) {
  LD_REQUIRE_DISPLAY();
  expectShowsTissue(screenshot(ld::test::resourcesDir() / "models" / "organ.obj", "organ"), 0.95);
}

TEST(GuiScreenshot, SharedSofaLiver) {
  LD_REQUIRE_DISPLAY();
  LD_REQUIRE_SHARED_DATA(liver, "meshes/sofa_liver.obj");
  // An irregular organ: some tissue in the middle is enough.
  expectShowsTissue(screenshot(liver, "liver"), 0.5);
}

#ifdef LD_GUI_HAVE_SIM_IO
TEST(GuiScreenshot, VrmlThroughTheImporters) {
  LD_REQUIRE_DISPLAY();
  expectShowsTissue(screenshot(ld::test::resourcesDir() / "models" / "tissue_slab_v2.wrl", "vrml"), 0.95);
}

TEST(GuiScreenshot, OpenMeshWithTwoSidedLighting) {
  LD_REQUIRE_DISPLAY();
  LD_REQUIRE_SHARED_DATA(hull, "meshes/lapgym_glt_liver_collision.stl");
  const Shot s = screenshot(hull, "hull");
  ASSERT_EQ(s.run.exitCode, 0) << s.run.err;
  ASSERT_FALSE(s.image.isNull());
}
#endif

#ifdef LD_GUI_HAVE_PHYSICS
// The JSON line --physics prints (the last line of stdout that starts with a brace).
nlohmann::json lastJson(const std::string& out) {
  const auto brace = out.rfind("\n{");
  const auto start = brace == std::string::npos ? out.find('{') : brace + 1;
  if (start == std::string::npos) return {};
  return nlohmann::json::parse(out.substr(start, out.find('\n', start) - start));
}

TEST(GuiScreenshot, PhysicsSettlesAndAPushDentsTheTissue) {
  LD_REQUIRE_DISPLAY();
  const Shot s = screenshot(ld::test::resourcesDir() / "models" / "tissue_slab.obj", "push",
                            "--physics --push 0,0,2.5,0,0,-300 --sim-time 0.5");
  expectShowsTissue(s, 0.5);
  const auto j = lastJson(s.run.out);
  ASSERT_TRUE(j.is_object()) << s.run.out;
  EXPECT_TRUE(j.at("settled").get<bool>());
  EXPECT_GE(j.at("sim_time_s").get<double>(), j.at("settle_sim_time_s").get<double>() + 0.5);
  const auto d = j.at("pushed_displacement");
  EXPECT_LT(d[2].get<double>(), -1.0) << "the pushed point moved down";
  EXPECT_LT(std::abs(d[0].get<double>()) + std::abs(d[1].get<double>()), 0.5) << "straight down";
  EXPECT_EQ(j.at("triangles").get<int>(), 10144);
}

#ifdef LD_GUI_HAVE_CUTTING
TEST(GuiScreenshot, ScalpelStrokeCutsAGrooveWithInteriorWalls) {
  LD_REQUIRE_DISPLAY();
  const Shot s = screenshot(ld::test::resourcesDir() / "models" / "tissue_slab.obj", "cut",
                            "--physics --cut -20,0,20,0,2 --sim-time 0.3 --zoom 4");
  ASSERT_EQ(s.run.exitCode, 0) << s.run.err;
  const auto j = lastJson(s.run.out);
  EXPECT_GT(j.at("triangles").get<int>(), 10144) << "the cut adds triangles";
  EXPECT_GT(j.at("cut_wall_triangles").get<int>(), 20) << "groove walls along a 40 mm stroke";
  // The loop's own figures: steps were run and timed, no frame had a non-finite position.
  EXPECT_GT(j.at("steps").get<long>(), 0);
  EXPECT_GT(j.at("step_us_mean").get<double>(), 0.0);
  EXPECT_EQ(j.at("nan_frames").get<long>(), 0);
  ASSERT_FALSE(s.image.isNull());
  // The groove shows as an interior-coloured line across the middle: some pixels of
  // the centre column have the interior's hue (green/red about 0.2; the surface's
  // is about 0.5 under any lighting).
  int interiorRows = 0;
  for (int y = 150; y < 250; ++y) {
    const QColor c = s.image.pixelColor(320, y);
    if (c.red() > 40 && c.greenF() < 0.35 * c.redF() && c.red() > c.blue()) ++interiorRows;
  }
  EXPECT_GT(interiorRows, 0) << "no groove visible at the image centre";
}

TEST(GuiScreenshot, CutThroughSeparatesAndKeepsBothPiecesVisible) {
  LD_REQUIRE_DISPLAY();
  const Shot s = screenshot(ld::test::resourcesDir() / "models" / "tissue_slab.obj", "through",
                            "--physics --cut -50,0,50,0,8 --sim-time 0.3");
  expectShowsTissue(s, 0.5);
  const auto j = lastJson(s.run.out);
  EXPECT_GT(j.at("triangles").get<int>(), 10144) << "both objects together";
  EXPECT_GT(j.at("cut_wall_triangles").get<int>(), 0);
  EXPECT_EQ(j.at("objects").get<int>(), 2) << "the cut-through freed the front half as an object of its own";
  // Both halves are still drawn: tissue above and below the cut line.
  EXPECT_TRUE(isTissue(s.image.pixel(320, 170)));
  EXPECT_TRUE(isTissue(s.image.pixel(320, 240)));
}
#endif

TEST(GuiScreenshot, PushWithoutPhysicsIsBadInput) {
  LD_REQUIRE_DISPLAY();
  const Shot s = screenshot(ld::test::resourcesDir() / "models" / "tissue_slab.obj", "nophys", "--push 0,0,0,0,0,1");
  EXPECT_EQ(s.run.exitCode, 2) << s.run.err;
}
#endif

TEST(GuiScreenshot, BadModelExitsWithTwoAndAPlace) {
  LD_REQUIRE_DISPLAY();
  const auto bad = std::filesystem::temp_directory_path() / ("ld_bad_" + std::to_string(::getpid()) + ".obj");
  { std::ofstream(bad) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"; }
  const Shot s = screenshot(bad, "bad");
  std::filesystem::remove(bad);
  EXPECT_EQ(s.run.exitCode, 2) << s.run.err;
  EXPECT_NE(s.run.err.find(bad.string() + ":"), std::string::npos) << s.run.err;
  EXPECT_TRUE(s.image.isNull()) << "no picture for a bad model";

  const Shot missing = screenshot("/nonexistent/model.obj", "missing");
  EXPECT_EQ(missing.run.exitCode, 2);
  EXPECT_NE(missing.run.err.find("/nonexistent/model.obj:"), std::string::npos) << missing.run.err;
}

TEST(GuiScreenshot, BadOptionsExitWithTwo) {
  LD_REQUIRE_DISPLAY();
  const auto r = runCommand(shellQuote(LD_GUI_BIN) + " --screenshot /tmp/x.png --size 10xfoo");
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_NE(r.err.find("--size"), std::string::npos) << r.err;
  const auto u = runCommand(shellQuote(LD_GUI_BIN) + " --no-such-option");
  EXPECT_EQ(u.exitCode, 2) << u.err;
  for (const char* bad :
       {"--physics --cut 1,2,3:4", "--physics --cut 0,0,1,1:-2", "--physics --cut 0,0,1,1:x", "--cut 0,0,10,0:2",
        "--physics --drag-piece 1,2,3", "--physics --cut 0,0,9,0:2 --drag-piece 1,2", "--orbit 0,95",
        "--physics --cut-speed 40", "--physics --cut 0,0,9,0:2 --cut-speed -1", "--physics --cut-live"}) {
    const auto c = runCommand(shellQuote(LD_GUI_BIN) + " --screenshot /tmp/x.png " + bad);
    EXPECT_EQ(c.exitCode, 2) << bad << ": " << c.err;
    EXPECT_NE(c.err.find("--"), std::string::npos) << bad << ": the message names the option: " << c.err;
  }
}

// Help and version are for terminals without a display too.
TEST(GuiScreenshot, HelpAndVersionNeedNoDisplay) {
  const auto h =
      runCommand("env -u DISPLAY -u WAYLAND_DISPLAY QT_QPA_PLATFORM=xcb " + shellQuote(LD_GUI_BIN) + " --help");
  EXPECT_EQ(h.exitCode, 0) << h.err;
  EXPECT_NE(h.out.find("--screenshot"), std::string::npos) << h.out;
  const auto v =
      runCommand("env -u DISPLAY -u WAYLAND_DISPLAY QT_QPA_PLATFORM=xcb " + shellQuote(LD_GUI_BIN) + " --version");
  EXPECT_EQ(v.exitCode, 0) << v.err;
  EXPECT_NE(v.out.find("lapdissect"), std::string::npos) << v.out;
}

#ifdef LD_GUI_HAVE_CUTTING
// The README's picture: a groove and a piece cut out and moved away (docs/images/cut_slab.png).
TEST(GuiScreenshot, PolylineStrokesCutOutAPieceThatIsDraggedAway) {
  LD_REQUIRE_DISPLAY();
  const Shot s = screenshot(ld::test::resourcesDir() / "models" / "tissue_slab.obj", "cutout",
                            "--physics --cut -30,10,15,10:3.5 --cut -50,-15,0,-15,50,-15:8 --drag-piece 0,-12,0 "
                            "--sim-time 0.5");
  ASSERT_EQ(s.run.exitCode, 0) << s.run.err;
  const auto j = lastJson(s.run.out);
  EXPECT_EQ(j.at("objects").get<int>(), 2) << "the through-cut freed the front strip";
  EXPECT_GT(j.at("cut_wall_triangles").get<int>(), 50) << "groove and side walls";
  // The strip was moved 12 mm toward the viewer: a background gap now runs between
  // it and the tissue somewhere below the middle of the picture.
  // Down the centre column: tissue, then background, then tissue again.
  int phase = 0;
  for (int y = 150; y < s.image.height(); ++y) {
    const bool t = isTissue(s.image.pixel(320, y));
    if ((phase == 0 && t) || (phase == 1 && !t) || (phase == 2 && t)) ++phase;
  }
  EXPECT_EQ(phase, 3) << "no gap between the tissue and the dragged piece at the image centre column";
}
#endif

TEST(GuiScreenshot, DatabaseUrlDoesNotStopAFirstStart) {
  LD_REQUIRE_DISPLAY();
  const auto dir = std::filesystem::temp_directory_path() / ("ld_nodb_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const auto file = dir / "store.sqlite";
  const Shot s =
      screenshot(ld::test::resourcesDir() / "models" / "disc.obj", "db", "--db " + shellQuote(file.string()));
  expectShowsTissue(s, 0.95);
#ifdef LD_GUI_HAVE_DB
  EXPECT_TRUE(std::filesystem::exists(file)) << "the first start creates the trainee store";
#endif
  // A store that cannot be opened is reported, not fatal.
  const Shot bad = screenshot(ld::test::resourcesDir() / "models" / "disc.obj", "baddb",
                              "--db " + shellQuote((dir / "missing-folder" / "x" / "store.sqlite").string()));
  expectShowsTissue(bad, 0.95);
  std::filesystem::remove_all(dir);
}

}  // namespace
