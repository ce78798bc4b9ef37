#include "app/gui/main_window.h"

#include <QAction>
#include <QActionGroup>
#include <QApplication>
#include <QDoubleSpinBox>
#include <QFileDialog>
#include <QFileInfo>
#include <QKeySequence>
#include <QLabel>
#include <QMenuBar>
#include <QMessageBox>
#include <QProgressDialog>
#include <QStatusBar>
#include <QTimer>
#include <QToolBar>

#include <algorithm>
#include <cmath>

#include "app/gui/mesh_view.h"
#include "app/gui/resource_paths.h"
#ifdef LD_GUI_HAVE_DB
#include "app/gui/login_dialog.h"
#endif
#ifdef LD_GUI_HAVE_PHYSICS
#include "app/gui/physics_session.h"
#endif

namespace ld::gui {

#ifndef LD_GUI_HAVE_PHYSICS
class PhysicsSession {  // never created: the physics module is not built
 public:
  static bool cuttingAvailable() { return false; }
};
#endif

bool MainWindow::physicsAvailable() {
#ifdef LD_GUI_HAVE_PHYSICS
  return true;
#else
  return false;
#endif
}

MainWindow::MainWindow(QWidget* parent) : QMainWindow(parent) {
  setWindowTitle(QStringLiteral("lapdissect"));
  view_ = new MeshView(this);
  setCentralWidget(view_);
  countsLabel_ = new QLabel(this);
  dbLabel_ = new QLabel(this);
  physicsLabel_ = new QLabel(this);
  statusBar()->addPermanentWidget(physicsLabel_);
  statusBar()->addPermanentWidget(dbLabel_);
  statusBar()->addPermanentWidget(countsLabel_);
  buildMenus();
  updateCounts();
  setDatabaseUrl({});

  frameTimer_ = new QTimer(this);
  frameTimer_->setInterval(16);  // about 60 frames per second
  connect(frameTimer_, &QTimer::timeout, this, &MainWindow::pollPhysics);
  view_->setPushEnabled(physicsAvailable());
  connect(view_, &MeshView::pushStarted, this, [this](std::size_t object, std::uint32_t v, const QVector3D& p) {
    if (object < shownIds_.size()) pushVertex_ = std::pair{shownIds_[object], v};
    pushTarget_ = p;
  });
  connect(view_, &MeshView::pushMoved, this, [this](const QVector3D& target) { pushTarget_ = target; });
  connect(view_, &MeshView::graspStarted, this, [this](std::size_t object, const QVector3D& p) {
    if (object < shownIds_.size()) grasped_ = shownIds_[object];
    graspLast_ = p;
  });
  connect(view_, &MeshView::graspMoved, this, [this](const QVector3D& target) {
#ifdef LD_GUI_HAVE_PHYSICS
    if (physics_ && grasped_) {
      const QVector3D d = target - graspLast_;
      physics_->movePiece(*grasped_, Eigen::Vector3d(d.x(), d.y(), d.z()));
    }
#endif
    graspLast_ = target;
  });
  connect(view_, &MeshView::graspEnded, this, [this] { grasped_.reset(); });
  connect(view_, &MeshView::cutStarted, this, [this](const QVector3D& p, const QVector3D& n) {
    cutting_ = true;
    cutLast_ = p;
    cutCursor_ = p;
    cutNormal_ = n;
  });
  connect(view_, &MeshView::cutMoved, this, [this](const QVector3D& p) {
    cutCursor_ = p;
    // Samples every half millimetre or more: the engine sub-samples long moves itself.
    if (cutting_ && (p - cutLast_).length() >= 0.5F) sendCutSample(p);
  });
  connect(view_, &MeshView::cutEnded, this, [this] {
    // The cursor's last stretch, however short, is cut too: a stroke released just past
    // the rim must reach it, or the piece it should free stays attached.
    if (cutting_ && (cutCursor_ - cutLast_).length() > 1e-3F) sendCutSample(cutCursor_);
    cutting_ = false;
#ifdef LD_GUI_HAVE_PHYSICS
    if (physics_) physics_->endCut();
#endif
  });
  connect(view_, &MeshView::pushEnded, this, [this] {
    pushVertex_.reset();
#ifdef LD_GUI_HAVE_PHYSICS
    if (physics_) physics_->release();
#endif
  });
}

MainWindow::~MainWindow() {
  ++loadId_;
  if (loader_.joinable()) loader_.join();
  physics_.reset();
}

void MainWindow::setPhysicsEnabled(bool on) {
  physicsEnabled_ = on && physicsAvailable();
  if (physicsAction_) physicsAction_->setChecked(physicsEnabled_);
  restartPhysics();
}

void MainWindow::restartPhysics() {
  physics_.reset();
  pushVertex_.reset();
  grasped_.reset();
  shownIds_.assign(1, 0);
  frameTimer_->stop();
  physicsLabel_->setText(physicsAvailable() ? tr("Physics: off") : QString());
  statusClock_.invalidate();  // a new session shows its status at the first poll
#ifdef LD_GUI_HAVE_PHYSICS
  if (!physicsEnabled_ || !original_) {
    if (original_) view_->setMesh(renderMeshFrom(*original_), false);  // back to the loaded shape
    return;
  }
  physics_ = std::make_unique<PhysicsSession>(*original_);
  physics_->setHoldWhileCutting(holdWhileCutting_);
  frameTimer_->start();
#endif
}

void MainWindow::sendCutSample(const QVector3D& p) {
#ifdef LD_GUI_HAVE_PHYSICS
  if (!physics_) return;
  const QVector3D motion = p - cutLast_;
  physics_->cutSample(Eigen::Vector3d(p.x(), p.y(), p.z()),
                      Eigen::Vector3d(cutNormal_.x(), cutNormal_.y(), cutNormal_.z()),
                      Eigen::Vector3d(motion.x(), motion.y(), motion.z()), view_->cutDepth());
#endif
  cutLast_ = p;
}

bool MainWindow::cutAcrossTop(double x0, double y0, double x1, double y1, double depth) {
  return cutStroke({QPointF(x0, y0), QPointF(x1, y1)}, depth);
}

bool MainWindow::cutStroke(const std::vector<QPointF>& xy, double depth, double speed) {
#ifdef LD_GUI_HAVE_PHYSICS
  if (!physics_ || !PhysicsSession::cuttingAvailable() || xy.size() < 2) return false;
  pollPhysics();
  const Bounds b = view_->mesh().bounds();
  const auto z = static_cast<double>(b.max[2]);
  // Samples every half millimetre along the polyline, the blade's sharp side facing
  // the motion of each leg; at a hand's speed the tissue moves between two samples.
  for (std::size_t i = 0; i + 1 < xy.size(); ++i) {
    const Eigen::Vector3d from(xy[i].x(), xy[i].y(), z), to(xy[i + 1].x(), xy[i + 1].y(), z);
    const Eigen::Vector3d motion = to - from;
    const int n = std::max(1, static_cast<int>(std::ceil(motion.norm() / 0.5)));
    for (int k = i == 0 ? 0 : 1; k <= n; ++k) {
      physics_->cutSample(from + (static_cast<double>(k) / n) * motion, Eigen::Vector3d::UnitZ(), motion, depth);
      if (speed > 0 && k < n) physics_->advance(motion.norm() / n / speed);
    }
    if (speed > 0 && i + 2 < xy.size()) physics_->advance(motion.norm() / n / speed);
  }
  physics_->endCut();
  return true;
#else
  (void)xy, (void)depth, (void)speed;
  return false;
#endif
}

void MainWindow::dragPieces(const QVector3D& delta, bool lastStrokeOnly) {
#ifdef LD_GUI_HAVE_PHYSICS
  if (!physics_) return;
  const Eigen::Vector3d d(delta.x(), delta.y(), delta.z());
  if (lastStrokeOnly)
    physics_->moveLastFreedPieces(d);
  else
    physics_->moveAllPieces(d);
#else
  (void)delta, (void)lastStrokeOnly;
#endif
}

void MainWindow::setHoldWhileCutting(bool on) {
  holdWhileCutting_ = on;
  if (holdAction_) holdAction_->setChecked(on);
#ifdef LD_GUI_HAVE_PHYSICS
  if (physics_) physics_->setHoldWhileCutting(on);
#endif
}

void MainWindow::syncPhysics() {
#ifdef LD_GUI_HAVE_PHYSICS
  if (physics_) physics_->sync();
#endif
  pollPhysics();
  showPhysicsStatus();
}

std::size_t MainWindow::objectCount() const { return view_->objects().size(); }

void MainWindow::pollPhysics() {
#ifdef LD_GUI_HAVE_PHYSICS
  if (!physics_) return;
  if (pushVertex_)
    physics_->pushToward(pushVertex_->first, pushVertex_->second,
                         Eigen::Vector3d(pushTarget_.x(), pushTarget_.y(), pushTarget_.z()));
  bool topologyChanged = false;
  SceneFrame frame;
  if (physics_->update(frame, topologyChanged)) {
    std::vector<std::array<Vec3f, 3>> preview;
    for (const auto& p : frame.preview) preview.push_back({p.from, p.to, p.depth});
    view_->setPreview(std::move(preview));
    if (topologyChanged) {
      shownIds_.clear();
      std::vector<RenderMesh> meshes;
      for (auto& o : frame.objects) {
        shownIds_.push_back(o.id);
        meshes.push_back(std::move(o.mesh));
      }
      view_->setObjects(std::move(meshes), false);
      updateCounts();
    } else {
      for (std::size_t i = 0; i < frame.objects.size(); ++i) view_->updatePositions(i, frame.objects[i].mesh.positions);
    }
  }
  // The status line's figures change every step; four times a second is readable and
  // keeps an idle window from repainting (and recompositing its GL view) at 60 Hz.
  if (topologyChanged || !statusClock_.isValid() || statusClock_.elapsed() >= 250) showPhysicsStatus();
#endif
}

void MainWindow::showPhysicsStatus() {
#ifdef LD_GUI_HAVE_PHYSICS
  if (!physics_) return;
  physicsLabel_->setText(physics_->status());
  statusClock_.restart();
#endif
}

void MainWindow::buildMenus() {
  QMenu* file = menuBar()->addMenu(tr("&File"));
  QAction* open = file->addAction(tr("&Open model..."), this, &MainWindow::openModel);
  open->setShortcut(QKeySequence::Open);
  QAction* reload = file->addAction(tr("Open the &default tissue"), this, [this] {
    const QString def = defaultModelPath();
    if (def.isEmpty())
      QMessageBox::warning(this, tr("lapdissect"), tr("The bundled models (resources/models) were not found."));
    else
      loadModelInBackground(def);
  });
  reload->setShortcut(QKeySequence(Qt::CTRL | Qt::Key_D));
  file->addSeparator();
  QAction* quit = file->addAction(tr("&Quit"), qApp, &QApplication::closeAllWindows);
  quit->setShortcut(QKeySequence::Quit);

  QMenu* view = menuBar()->addMenu(tr("&View"));
  wireframeAction_ = view->addAction(tr("&Wireframe"));
  wireframeAction_->setCheckable(true);
  wireframeAction_->setShortcut(QKeySequence(Qt::Key_W));
  connect(wireframeAction_, &QAction::toggled, view_, &MeshView::setWireframe);
  QAction* twoSided = view->addAction(tr("&Two-sided lighting"));
  twoSided->setCheckable(true);
  twoSided->setChecked(view_->twoSided());
  connect(twoSided, &QAction::toggled, view_, &MeshView::setTwoSided);
  view->addSeparator();
  QAction* fit = view->addAction(tr("&Fit to view"), view_, &MeshView::fitToView);
  fit->setShortcut(QKeySequence(Qt::Key_F));
  QAction* reset = view->addAction(tr("&Reset view"), view_, &MeshView::resetView);
  reset->setShortcut(QKeySequence(Qt::Key_R));

  if (physicsAvailable()) {
    QMenu* sim = menuBar()->addMenu(tr("&Simulation"));
    physicsAction_ = sim->addAction(tr("&Run physics"));
    physicsAction_->setCheckable(true);
    physicsAction_->setChecked(physicsEnabled_);
    physicsAction_->setShortcut(QKeySequence(Qt::Key_Space));
    connect(physicsAction_, &QAction::toggled, this, [this](bool on) {
      if (on != physicsEnabled_) setPhysicsEnabled(on);
    });
    sim->addAction(tr("R&estart from the loaded model"), this, [this] { restartPhysics(); });
    holdAction_ = sim->addAction(tr("&Hold the tissue still while cutting"));
    holdAction_->setCheckable(true);
    holdAction_->setChecked(holdWhileCutting_);
    holdAction_->setToolTip(tr(
        "The wound opens when the blade lifts, and cut-out pieces come free (off: the tissue moves under the blade)"));
    connect(holdAction_, &QAction::toggled, this, [this](bool on) { setHoldWhileCutting(on); });
    sim->addSeparator();
    // What a plain left drag does: orbit the camera, push the tissue, or cut it.
    auto* group = new QActionGroup(this);
    QAction* orbit = sim->addAction(tr("Left drag &orbits"));
    QAction* push = sim->addAction(tr("Left drag &pushes"));
    QAction* cut = sim->addAction(tr("Left drag &cuts (scalpel)"));
    QAction* grasp = sim->addAction(tr("Left drag &grasps a freed piece"));
    for (QAction* a : {orbit, push, cut, grasp}) {
      a->setCheckable(true);
      group->addAction(a);
    }
    orbit->setChecked(true);
    orbit->setShortcut(QKeySequence(Qt::Key_1));
    push->setShortcut(QKeySequence(Qt::Key_2));
    cut->setShortcut(QKeySequence(Qt::Key_3));
    grasp->setShortcut(QKeySequence(Qt::Key_4));
    cut->setEnabled(PhysicsSession::cuttingAvailable());
    grasp->setEnabled(PhysicsSession::cuttingAvailable());
    connect(orbit, &QAction::triggered, this, [this] { view_->setLeftDrag(LeftDrag::Orbit); });
    connect(push, &QAction::triggered, this, [this] { view_->setLeftDrag(LeftDrag::Push); });
    connect(cut, &QAction::triggered, this, [this] { view_->setLeftDrag(LeftDrag::Cut); });
    connect(grasp, &QAction::triggered, this, [this] { view_->setLeftDrag(LeftDrag::Grasp); });

    QToolBar* tools = addToolBar(tr("Tools"));
    tools->addAction(orbit);
    tools->addAction(push);
    tools->addAction(cut);
    tools->addAction(grasp);
    tools->addSeparator();
    cutDepth_ = new QDoubleSpinBox(this);
    cutDepth_->setRange(0.2, 20.0);
    cutDepth_->setSingleStep(0.5);
    cutDepth_->setValue(2.0);
    cutDepth_->setSuffix(tr(" mm"));
    cutDepth_->setToolTip(tr("Scalpel depth below the surface (deeper than the tissue cuts through)"));
    tools->addWidget(new QLabel(tr(" Cut depth "), this));
    tools->addWidget(cutDepth_);
    view_->setCutDepth(cutDepth_->value());
    connect(cutDepth_, &QDoubleSpinBox::valueChanged, view_, &MeshView::setCutDepth);
  }

  QMenu* trainee = menuBar()->addMenu(tr("&Trainee"));
  QAction* login = trainee->addAction(tr("&Log in..."), this, &MainWindow::showLogin);
  login->setShortcut(QKeySequence(Qt::CTRL | Qt::Key_L));
  trainee->addAction(tr("Log &out"), this, [this] {
#ifdef LD_GUI_HAVE_DB
    session_.reset();
#endif
    dbLabel_->setText(storeStatus());
  });

  QMenu* help = menuBar()->addMenu(tr("&Help"));
  help->addAction(tr("&Mouse controls"), this, [this] {
    QMessageBox::information(this, tr("Mouse controls"),
                             tr("Left drag: orbit\nRight or middle drag, or Shift + left drag: pan\n"
                                "Wheel: zoom\nDouble click or F: fit to view\nW: wireframe\n"
                                "Ctrl + left drag: push or pull the tissue (physics running)\n"
                                "1 / 2 / 3 / 4: left drag orbits / pushes / cuts at the toolbar's depth (the scalpel "
                                "follows the cursor) / grasps and moves a piece cut free\nSpace: physics on/off"));
  });
  help->addAction(tr("&About"), this, [this] {
    QMessageBox::about(
        this, tr("About lapdissect"),
        tr("lapdissect: laparoscopic tissue-dissection training.\nRenderer: %1").arg(view_->rendererInfo()));
  });
}

void MainWindow::setDatabaseUrl(const QString& url) {
  dbUrl_ = url;
  dbLabel_->setText(storeStatus());
}

QString MainWindow::storeStatus() const {
#ifdef LD_GUI_HAVE_DB
  if (store_) {
    const QString where = QString::fromStdString(store_->location());
    return session_ ? tr("Store: %1, %2 (%3)")
                          .arg(where, QString::fromStdString(session_->name()),
                               QString::fromStdString(db::toString(session_->role())))
                    : tr("Store: %1, not logged in").arg(where);
  }
#endif
  if (!storeError_.isEmpty()) return tr("Store unavailable");
  return dbUrl_.isEmpty() ? tr("Store: default (not opened)") : tr("Store: %1 (not opened)").arg(dbUrl_);
}

bool MainWindow::openStore() {
#ifdef LD_GUI_HAVE_DB
  if (store_) return true;
  try {
    store_ = db::Store::open(dbUrl_.isEmpty() ? db::Store::defaultUrl() : dbUrl_.toStdString());
    storeError_.clear();
  } catch (const std::exception& e) {
    storeError_ = QString::fromUtf8(e.what());
    statusBar()->showMessage(tr("Trainee store unavailable: %1").arg(storeError_), 15000);
  }
  dbLabel_->setText(storeStatus());
  dbLabel_->setToolTip(storeError_);
  return store_.has_value();
#else
  storeError_ = tr("this build has no trainee store (ld_database)");
  dbLabel_->setText(storeStatus());
  return false;
#endif
}

void MainWindow::showLogin() {
#ifdef LD_GUI_HAVE_DB
  if (!openStore()) {
    QMessageBox::warning(this, tr("Log in"), tr("The trainee store cannot be opened:\n%1").arg(storeError_));
    return;
  }
  LoginDialog dialog(*store_, this);
  if (dialog.exec() == QDialog::Accepted && dialog.session()) session_ = dialog.session();
  dbLabel_->setText(storeStatus());
#else
  QMessageBox::information(this, tr("Log in"), tr("This build has no trainee store."));
#endif
}

void MainWindow::updateCounts() {
  // Vertices the triangles use (the simulation's lists keep deleted slots), over all objects.
  std::size_t vertices = 0, triangles = 0;
  for (const RenderMesh& m : view_->objects()) {
    std::vector<bool> used(m.positions.size(), false);
    for (const auto& t : m.triangles)
      for (auto v : t) used[v] = true;
    vertices += static_cast<std::size_t>(std::count(used.begin(), used.end(), true));
    triangles += m.triangles.size();
  }
  QString text = tr("Vertices: %1   Triangles: %2").arg(vertices).arg(triangles);
  if (view_->objects().size() > 1) text += tr("   Objects: %1").arg(view_->objects().size());
  countsLabel_->setText(text);
}

void MainWindow::showModel(LoadedModel model) {
  currentFile_ = QString::fromStdString(model.file.string());
  const auto warnings = model.warnings.size();
  view_->setMesh(std::move(model.mesh));
#ifdef LD_GUI_HAVE_SIM_IO
  original_ = std::move(model.surface);
#endif
  restartPhysics();
  updateCounts();
  setWindowTitle(QStringLiteral("lapdissect - %1").arg(QFileInfo(currentFile_).fileName()));
  const QString name = QFileInfo(currentFile_).fileName();
  statusBar()->showMessage(warnings ? tr("Loaded %1 (%2 warnings)").arg(name).arg(warnings) : tr("Loaded %1").arg(name),
                           8000);
  emit modelLoaded(currentFile_);
}

void MainWindow::loadModelNow(const QString& file) { showModel(loadModel(file.toStdString())); }

void MainWindow::openModel() {
  const QString start =
      currentFile_.isEmpty() ? findResourcesDir() + "/models" : QFileInfo(currentFile_).absolutePath();
  const QString file = QFileDialog::getOpenFileName(this, tr("Open model"), start, modelFileFilter());
  if (!file.isEmpty()) loadModelInBackground(file);
}

void MainWindow::loadModelInBackground(const QString& file) {
  const unsigned id = ++loadId_;
  if (loader_.joinable()) loader_.join();  // a stale load finishes; its result is dropped

  if (!progress_) {
    progress_ = new QProgressDialog(this);
    progress_->setWindowModality(Qt::WindowModal);
    progress_->setMinimumDuration(300);  // small files load before it appears
    progress_->setAutoClose(false);
    progress_->setAutoReset(false);
    connect(progress_, &QProgressDialog::canceled, this, [this] {
      ++loadId_;
      progress_->hide();
      statusBar()->showMessage(tr("Loading cancelled"), 5000);
    });
  }
  const qint64 bytes = QFileInfo(file).size();
  progress_->setLabelText(
      tr("Loading %1 (%2 MB)...").arg(QFileInfo(file).fileName()).arg(bytes / 1048576.0, 0, 'f', 1));
  progress_->setRange(0, 0);  // the importers report no progress: a busy bar
  progress_->reset();
  progress_->show();

  loader_ = std::thread([this, id, path = file.toStdString()] {
    auto model = std::make_shared<LoadedModel>();
    QString error;
    try {
      *model = loadModel(path);
    } catch (const std::exception& e) {
      error = QString::fromUtf8(e.what());
    }
    // The window outlives this thread (its destructor joins), so queuing to it is safe.
    QMetaObject::invokeMethod(
        this, [this, id, model, error] { finishLoad(id, model, error); }, Qt::QueuedConnection);
  });
}

void MainWindow::finishLoad(unsigned id, std::shared_ptr<LoadedModel> model, const QString& error) {
  if (id != loadId_) return;  // cancelled or superseded
  if (progress_) progress_->hide();
  if (!error.isEmpty()) {
    statusBar()->showMessage(error, 10000);
    emit modelFailed(error);
    QMessageBox::critical(this, tr("Cannot open model"), error);
    return;
  }
  showModel(std::move(*model));
}

}  // namespace ld::gui
