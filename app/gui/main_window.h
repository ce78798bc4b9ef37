#pragma once
// The main window: the 3-D view, File and View menus, and a status bar with the
// model's vertex and triangle counts. Models load on a worker thread behind a
// progress dialog so a large file does not freeze the window.
#include <QElapsedTimer>
#include <QMainWindow>
#include <QString>

#include <QPointF>

#include <memory>
#include <thread>
#include <utility>
#include <vector>

#include "app/gui/model_loader.h"
#ifdef LD_GUI_HAVE_DB
#include "database/store.h"
#endif

class QLabel;
class QTimer;
class QProgressDialog;
class QAction;
class QDoubleSpinBox;

#include <QVector3D>

namespace ld::gui {

class MeshView;
class PhysicsSession;

class MainWindow : public QMainWindow {
  Q_OBJECT

 public:
  explicit MainWindow(QWidget* parent = nullptr);
  ~MainWindow() override;

  [[nodiscard]] MeshView* view() const { return view_; }
  // Loads on the calling thread (start-up, screenshots). Throws ModelLoadError.
  void loadModelNow(const QString& file);
  // Loads on a worker thread with a progress dialog; errors are shown in a message box.
  void loadModelInBackground(const QString& file);
  void showModel(LoadedModel model);
  // The trainee store: `url` empty means the default file in the user's data folder.
  // openStore() opens (creating and migrating on a first start); a failure is shown
  // in the status bar and never stops the program. Returns whether a store is open.
  void setDatabaseUrl(const QString& url);
  bool openStore();
  void showLogin();
  [[nodiscard]] QString storeStatus() const;

  // The tissue simulation (when the physics module is built): runs on models loaded
  // through the importers while enabled.
  [[nodiscard]] static bool physicsAvailable();
  void setPhysicsEnabled(bool on);
  [[nodiscard]] PhysicsSession* physics() const { return physics_.get(); }
  // Pulls the latest snapshot into the view (the frame timer calls it); a tissue at rest
  // publishes none, so the view is not redrawn. The status line follows at 4 Hz.
  void pollPhysics();
  // Sets the physics status line now.
  void showPhysicsStatus();
  // One straight scalpel stroke across the top of the tissue (scripted cutting):
  // from (x0, y0) to (x1, y1) at `depth` mm below the highest point.
  bool cutAcrossTop(double x0, double y0, double x1, double y1, double depth);
  // A scalpel stroke along a polyline (x, y pairs) across the top, `depth` mm deep.
  // `speed` > 0 [mm/s] paces the samples as a hand would (the simulation runs between
  // them, so the wound opens behind the blade); 0 makes the whole stroke between two
  // steps. Returns false without the cutting module.
  bool cutStroke(const std::vector<QPointF>& xy, double depth, double speed = 0.0);
  // Moves every piece cut free so far by `delta` mm (as a grasp would), or only
  // those the last stroke that freed any freed.
  void dragPieces(const QVector3D& delta, bool lastStrokeOnly = false);
  // Hold the tissue still while the blade is in it (default; see PhysicsSession).
  void setHoldWhileCutting(bool on);
  // Blocks until the simulation has run every command sent so far.
  void syncPhysics();
  // The objects as last shown: index 0 the tissue, then the pieces cut free.
  [[nodiscard]] std::size_t objectCount() const;

 public slots:
  void openModel();

 signals:
  void modelLoaded(const QString& file);
  void modelFailed(const QString& reason);

 private:
  void buildMenus();
  void finishLoad(unsigned id, std::shared_ptr<LoadedModel> model, const QString& error);
  void updateCounts();
  void restartPhysics();
  void sendCutSample(const QVector3D& p);  // one scalpel sample at the cursor's point

  MeshView* view_ = nullptr;
  QLabel* countsLabel_ = nullptr;
  QLabel* dbLabel_ = nullptr;
  QAction* wireframeAction_ = nullptr;
  QProgressDialog* progress_ = nullptr;
  std::thread loader_;
  unsigned loadId_ = 0;  // a newer load or a cancel makes older results stale
  QString currentFile_;
  QString dbUrl_;
  QString storeError_;
#ifdef LD_GUI_HAVE_DB
  std::optional<db::Store> store_;
  std::optional<db::Session> session_;
#endif

  std::unique_ptr<PhysicsSession> physics_;
  bool physicsEnabled_ = true;
  QAction* physicsAction_ = nullptr;
  QAction* holdAction_ = nullptr;
  bool holdWhileCutting_ = true;
  QLabel* physicsLabel_ = nullptr;
  QElapsedTimer statusClock_;  // when the physics status line was last set
  QTimer* frameTimer_ = nullptr;
#ifdef LD_GUI_HAVE_SIM_IO
  std::optional<mesh::SurfaceMesh> original_;  // the model as loaded, to restart from
#endif
  QDoubleSpinBox* cutDepth_ = nullptr;
  QVector3D cutLast_, cutNormal_, cutCursor_;  // last point sent, stroke normal, cursor
  bool cutting_ = false;
  std::optional<std::pair<int, std::uint32_t>> pushVertex_;  // object id, vertex
  QVector3D pushTarget_;
  std::optional<int> grasped_;  // object id of the grasped piece
  QVector3D graspLast_;
  std::vector<int> shownIds_;  // object ids in the view's order
};

}  // namespace ld::gui
