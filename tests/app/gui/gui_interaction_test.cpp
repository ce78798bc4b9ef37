// Drives the real window with synthetic mouse events: Ctrl+drag pushes the tissue,
// a drag in scalpel mode cuts it. Needs an X display (skips without DISPLAY).
#include <QApplication>
#include <QElapsedTimer>
#include <QLabel>
#include <QMouseEvent>

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <memory>

#include "app/gui/main_window.h"
#ifdef LD_GUI_HAVE_DB
#include "app/gui/login_dialog.h"
#endif
#include "app/gui/mesh_view.h"
#include "app/gui/physics_session.h"
#include "tests/support/test_support.h"

namespace {

using ld::gui::MainWindow;
using ld::gui::MeshView;

bool haveDisplay() { return std::getenv("DISPLAY") && *std::getenv("DISPLAY"); }

// Runs the event loop until cond holds (generous wall-clock bound, not a timing test).
bool spinUntil(const std::function<bool()>& cond, int ms = 60000) {
  QElapsedTimer t;
  t.start();
  while (!cond()) {
    if (t.elapsed() > ms) return false;
    QApplication::processEvents(QEventLoop::AllEvents, 20);
  }
  return true;
}

void mouse(MeshView* v, QEvent::Type type, QPointF p, Qt::MouseButton button, Qt::KeyboardModifiers mods) {
  const Qt::MouseButtons buttons = type == QEvent::MouseButtonRelease ? Qt::NoButton : Qt::MouseButtons(Qt::LeftButton);
  QMouseEvent e(type, p, v->mapToGlobal(p), button, buttons, mods);
  QApplication::sendEvent(v, &e);
}

class GuiInteraction : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!haveDisplay()) GTEST_SKIP() << "no X display (DISPLAY unset): run under xvfb-run";
    static int argc = 1;
    static char name[] = "ld_gui_interaction_test";
    static char* argv[] = {name, nullptr};
    if (!QApplication::instance()) app_ = new QApplication(argc, argv);
    window_ = std::make_unique<MainWindow>();
    window_->setPhysicsEnabled(true);
    window_->view()->setFixedSize(640, 400);
    window_->loadModelNow(QString::fromStdString((ld::test::resourcesDir() / "models" / "tissue_slab.obj").string()));
    window_->show();
    window_->view()->fitToView();
    ASSERT_TRUE(spinUntil([&] { return window_->physics() && window_->physics()->settled(); }));
    spinUntil([] { return false; }, 200);  // a few frames
  }
  void TearDown() override { window_.reset(); }

  QApplication* app_ = nullptr;  // kept for the process (Qt wants one per process)
  std::unique_ptr<MainWindow> window_;
};

TEST_F(GuiInteraction, CtrlDragPushesTheTissueAndReleaseLetsItBack) {
  MeshView* v = window_->view();
  const QPointF centre(320, 200);
  const auto hit = v->pick(centre);
  ASSERT_TRUE(hit.has_value()) << "the slab is under the centre of the view";
  const float z0 = v->mesh().positions[hit->vertex][2];
  mouse(v, QEvent::MouseButtonPress, centre, Qt::LeftButton, Qt::ControlModifier);
  // Drag down the screen: the cursor's point goes below and toward the viewer.
  for (int k = 1; k <= 10; ++k)
    mouse(v, QEvent::MouseMove, centre + QPointF(0, 4.0 * k), Qt::NoButton, Qt::ControlModifier);
  ASSERT_TRUE(spinUntil([&] { return v->mesh().positions[hit->vertex][2] < z0 - 0.5F; }))
      << "the picked vertex did not follow the cursor";
  mouse(v, QEvent::MouseButtonRelease, centre + QPointF(0, 40), Qt::LeftButton, Qt::ControlModifier);
  EXPECT_TRUE(spinUntil([&] { return std::abs(v->mesh().positions[hit->vertex][2] - z0) < 0.1F; }))
      << "the tissue did not return after release";
}

TEST_F(GuiInteraction, DragInScalpelModeCutsAGroove) {
  if (!ld::gui::PhysicsSession::cuttingAvailable()) GTEST_SKIP() << "no cutting module in this build";
  MeshView* v = window_->view();
  const std::size_t before = v->mesh().triangles.size();
  v->setLeftDrag(ld::gui::LeftDrag::Cut);
  const QPointF start(240, 200);
  ASSERT_TRUE(v->pick(start).has_value());
  // Hovering: the scalpel stands at the cursor, its tip the set depth under the surface.
  v->setCutDepth(3.0);
  mouse(v, QEvent::MouseMove, start, Qt::NoButton, Qt::NoModifier);
  ASSERT_TRUE(v->scalpel().has_value()) << "no scalpel at the cursor in cut mode";
  const auto surface = v->pick(start);
  ASSERT_TRUE(surface.has_value());
  EXPECT_NEAR((surface->point - v->scalpel()->tip).length(), 3.0F, 0.05F);
  EXPECT_NEAR(v->scalpel()->tip.z(), surface->point.z() - 3.0F, 0.1F) << "straight down into the top face";
  mouse(v, QEvent::MouseButtonPress, start, Qt::LeftButton, Qt::NoModifier);
  // The cut follows the blade at once: while the stroke is open, the engine's preview
  // (the blade's point inside the current triangle) is drawn.
  bool previewShown = false;
  for (int k = 1; k <= 40; ++k) {
    mouse(v, QEvent::MouseMove, start + QPointF(4.0 * k, 0), Qt::NoButton, Qt::NoModifier);
    window_->syncPhysics();
    previewShown = previewShown || !v->preview().empty();
  }
  EXPECT_TRUE(previewShown) << "no preview segment while cutting";
  EXPECT_GT(v->scalpel()->tip.x(), surface->point.x() + 10.0F) << "the scalpel followed the cursor";
  mouse(v, QEvent::MouseButtonRelease, start + QPointF(160, 0), Qt::LeftButton, Qt::NoModifier);
  window_->syncPhysics();
  EXPECT_TRUE(v->preview().empty()) << "the preview ends with the stroke";
  ASSERT_TRUE(spinUntil([&] { return v->mesh().triangles.size() > before; })) << "no triangles were added";
  ASSERT_TRUE(spinUntil([&] {
    const auto& k = v->mesh().faceKind;
    return std::count_if(k.begin(), k.end(), [](auto x) { return x != 0; }) > 10;
  })) << "no groove walls";
  EXPECT_TRUE(window_->physics()->status().contains("cut"));
}

TEST_F(GuiInteraction, BackgroundLoadShowsTheModelAndItsCounts) {
  bool loaded = false;
  QString failure;
  QObject::connect(window_.get(), &MainWindow::modelLoaded, [&] { loaded = true; });
  QObject::connect(window_.get(), &MainWindow::modelFailed, [&](const QString& e) { failure = e; });
  window_->loadModelInBackground(QString::fromStdString((ld::test::resourcesDir() / "models" / "organ.obj").string()));
  ASSERT_TRUE(spinUntil([&] { return loaded || !failure.isEmpty(); })) << "the load never finished";
  ASSERT_TRUE(failure.isEmpty()) << failure.toStdString();
  ASSERT_TRUE(spinUntil([&] { return window_->view()->mesh().triangles.size() == 9680u; }));
  // The status bar names both counts.
  bool countsShown = false;
  for (const QLabel* l : window_->findChildren<QLabel*>())
    if (l->text().contains("Vertices: 4842") && l->text().contains("Triangles: 9680")) countsShown = true;
  EXPECT_TRUE(countsShown);
}

#ifdef LD_GUI_HAVE_DB
TEST(LoginDialog, FirstStartCreatesTheAdministratorThenLogsIn) {
  if (!haveDisplay()) GTEST_SKIP() << "no X display (DISPLAY unset): run under xvfb-run";
  static int argc = 1;
  static char name[] = "ld_gui_interaction_test";
  static char* argv[] = {name, nullptr};
  if (!QApplication::instance()) new QApplication(argc, argv);
  const auto file = std::filesystem::temp_directory_path() / ("ld_login_" + std::to_string(::getpid()) + ".sqlite");
  std::filesystem::remove(file);
  ld::db::Options cheap;  // fast password hashing for the test
  cheap.opsLimit = 1;
  cheap.memLimit = 8192;
  {
    auto store = ld::db::Store::open(file.string(), cheap);
    ld::gui::LoginDialog first(store);
    EXPECT_TRUE(first.createsFirstAdmin());
    EXPECT_FALSE(first.tryLogin("admin", "correct-horse-1", "correct-horse-2"));
    EXPECT_FALSE(first.error().isEmpty());
    EXPECT_FALSE(first.tryLogin("", "correct-horse-1", "correct-horse-1"));
    ASSERT_TRUE(first.tryLogin("admin", "correct-horse-1", "correct-horse-1")) << first.error().toStdString();
    EXPECT_EQ(first.session()->role(), ld::db::Role::Admin);

    ld::gui::LoginDialog again(store);
    EXPECT_FALSE(again.createsFirstAdmin());
    EXPECT_FALSE(again.tryLogin("admin", "wrong"));
    EXPECT_FALSE(again.error().isEmpty()) << "a wrong password is reported";
    EXPECT_TRUE(again.tryLogin("admin", "correct-horse-1")) << again.error().toStdString();
    EXPECT_EQ(again.session()->name(), "admin");
  }
  std::filesystem::remove(file);
}
#endif

}  // namespace
