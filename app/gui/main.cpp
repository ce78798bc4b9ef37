// lapdissect: the desktop program.
//   lapdissect [--model FILE] [--db URL] [--wireframe] [--no-physics]
//              [--screenshot OUT.png [--size WxH] [--whole-window] [--zoom STEPS] [--orbit YAW,PITCH]
//               [--physics [--push X,Y,Z,FX,FY,FZ] [--cut X0,Y0,X1,Y1[,...]:DEPTH]... [--cut-speed MM/S] [--cut-live]
//                          [--drag-piece DX,DY,DZ] [--show-scalpel] [--sim-time S]]]
// With --physics the screenshot is taken after the tissue has settled and run for
// --sim-time simulated seconds (with the --push force at the vertex nearest X,Y,Z,
// the scalpel strokes across the top along each --cut polyline, DEPTH mm deep, in
// order, and the pieces the last freeing stroke cut free moved by --drag-piece);
// a JSON line with the simulation's figures goes to stdout.
// With --screenshot it renders one frame of the model to OUT.png and exits
// (0 on success, 2 on bad input, 1 when rendering or writing fails).
#include <memory>
#include <string_view>

#include <QApplication>
#include <QCommandLineParser>
#include <QImage>
#include <QPixmap>
#include <QRegularExpression>
#include <QSurfaceFormat>
#include <QTimer>

#include <QElapsedTimer>
#include <QStringList>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "app/gui/main_window.h"
#include "app/gui/mesh_view.h"
#include "app/gui/resource_paths.h"
#ifdef LD_GUI_HAVE_PHYSICS
#include "app/gui/physics_session.h"
#endif

namespace {

constexpr int kBadInput = 2;

void printError(const QString& s) { std::fprintf(stderr, "lapdissect: %s\n", qPrintable(s)); }

#ifdef LD_GUI_HAVE_PHYSICS
// The referenced vertex nearest p (first three entries).
std::optional<std::size_t> nearestVertex(const ld::gui::RenderMesh& m, const std::array<double, 6>& p) {
  std::optional<std::size_t> best;
  double bestD = std::numeric_limits<double>::infinity();
  for (const auto& t : m.triangles)
    for (auto v : t) {
      double d = 0;
      for (std::size_t a = 0; a < 3; ++a) d += std::pow(static_cast<double>(m.positions[v][a]) - p[a], 2);
      if (d < bestD) {
        bestD = d;
        best = v;
      }
    }
  return best;
}
#endif

std::optional<std::vector<double>> numbers(const QString& s) {
  std::vector<double> out;
  for (const QString& part : s.split(',')) {
    bool ok = false;
    out.push_back(part.trimmed().toDouble(&ok));
    if (!ok || !std::isfinite(out.back())) return std::nullopt;
  }
  return out;
}

struct Stroke {
  std::vector<QPointF> points;
  double depth = 0;
};

// "X0,Y0,X1,Y1[,...]:DEPTH", or the straight "X0,Y0,X1,Y1,DEPTH".
std::optional<Stroke> parseStroke(const QString& value) {
  Stroke s;
  std::optional<std::vector<double>> xy;
  const QStringList parts = value.split(':');
  if (parts.size() == 2) {
    xy = numbers(parts[0]);
    bool ok = false;
    s.depth = parts[1].trimmed().toDouble(&ok);
    if (!ok || !xy || xy->size() < 4 || xy->size() % 2 != 0) return std::nullopt;
  } else if (parts.size() == 1) {
    xy = numbers(parts[0]);
    if (!xy || xy->size() != 5) return std::nullopt;
    s.depth = xy->back();
    xy->pop_back();
  } else {
    return std::nullopt;
  }
  if (!(s.depth > 0.0) || s.depth > 100.0) return std::nullopt;
  for (std::size_t i = 0; i < xy->size(); i += 2) s.points.emplace_back((*xy)[i], (*xy)[i + 1]);
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  QSurfaceFormat format;
  format.setVersion(3, 3);
  format.setProfile(QSurfaceFormat::CoreProfile);
  format.setDepthBufferSize(24);
  format.setSamples(4);
  QSurfaceFormat::setDefaultFormat(format);

  // --help and --version need no display: a GUI application would abort without one.
  bool infoOnly = false;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    infoOnly =
        infoOnly || a == "--help" || a == "-h" || a == "-?" || a == "--help-all" || a == "--version" || a == "-v";
  }
  std::unique_ptr<QCoreApplication> app;
  if (infoOnly)
    app = std::make_unique<QCoreApplication>(argc, argv);
  else
    app = std::make_unique<QApplication>(argc, argv);
  QApplication::setApplicationName(QStringLiteral("lapdissect"));
  QApplication::setOrganizationName(QStringLiteral("lapdissect"));
  QApplication::setApplicationVersion(QStringLiteral("0.1.0"));

  QCommandLineParser parser;
  parser.setApplicationDescription(QStringLiteral("Laparoscopic tissue-dissection training workstation"));
  parser.addHelpOption();
  parser.addVersionOption();
  const QCommandLineOption modelOpt(QStringLiteral("model"),
                                    QStringLiteral("Model to open (default: the bundled tissue slab)."),
                                    QStringLiteral("FILE"));
  const QCommandLineOption shotOpt(QStringLiteral("screenshot"),
                                   QStringLiteral("Render one frame to a PNG file and exit."),
                                   QStringLiteral("OUT.png"));
  const QCommandLineOption sizeOpt(QStringLiteral("size"),
                                   QStringLiteral("View size for --screenshot (default 1280x800)."),
                                   QStringLiteral("WxH"), QStringLiteral("1280x800"));
  const QCommandLineOption windowOpt(
      QStringLiteral("whole-window"),
      QStringLiteral("With --screenshot: capture the whole window (menus, status bar), not just the view."));
  const QCommandLineOption wireOpt(QStringLiteral("wireframe"), QStringLiteral("Start with the wireframe overlay on."));
  const QCommandLineOption dbOpt(QStringLiteral("db"),
                                 QStringLiteral("Trainee store URL (sqlite:PATH or postgresql://...)."),
                                 QStringLiteral("URL"));
  const QCommandLineOption noPhysicsOpt(QStringLiteral("no-physics"),
                                        QStringLiteral("Do not run the tissue simulation."));
  const QCommandLineOption physicsOpt(QStringLiteral("physics"),
                                      QStringLiteral("With --screenshot: settle and simulate the tissue first."));
  const QCommandLineOption pushOpt(QStringLiteral("push"),
                                   QStringLiteral("With --physics: force [mN] at the vertex nearest a point [mm]."),
                                   QStringLiteral("X,Y,Z,FX,FY,FZ"));
  const QCommandLineOption zoomOpt(QStringLiteral("zoom"),
                                   QStringLiteral("With --screenshot: zoom in by this many wheel steps after fitting."),
                                   QStringLiteral("STEPS"), QStringLiteral("0"));
  const QCommandLineOption cutOpt(
      QStringLiteral("cut"),
      QStringLiteral("With --physics: a scalpel stroke across the top along the polyline (X,Y pairs) [mm], DEPTH mm "
                     "deep (deeper than the tissue cuts through). Repeat for more strokes, made in order. "
                     "X0,Y0,X1,Y1,DEPTH (five numbers) is a straight stroke."),
      QStringLiteral("X0,Y0,X1,Y1[,...]:DEPTH"));
  const QCommandLineOption dragOpt(
      QStringLiteral("drag-piece"),
      QStringLiteral("With --cut: grasp the piece(s) the last freeing stroke cut free and move them by DX,DY,DZ mm."),
      QStringLiteral("DX,DY,DZ"));
  const QCommandLineOption orbitOpt(
      QStringLiteral("orbit"), QStringLiteral("With --screenshot: camera yaw and pitch in degrees (default -90,50)."),
      QStringLiteral("YAW,PITCH"));
  const QCommandLineOption scalpelOpt(QStringLiteral("show-scalpel"),
                                      QStringLiteral("With --cut: draw the scalpel where the last stroke ended."));
  const QCommandLineOption cutSpeedOpt(
      QStringLiteral("cut-speed"),
      QStringLiteral("With --cut: move the scalpel at this speed [mm/s], the simulation running between samples as "
                     "under a hand (default 0: each stroke at once, between two steps)."),
      QStringLiteral("MM/S"), QStringLiteral("0"));
  const QCommandLineOption cutLiveOpt(
      QStringLiteral("cut-live"),
      QStringLiteral("With --cut: keep simulating while the blade is in the tissue (default: the tissue is held still "
                     "during a stroke and opens when the blade lifts)."));
  const QCommandLineOption simTimeOpt(QStringLiteral("sim-time"),
                                      QStringLiteral("With --physics: simulated seconds after settling (default 0.5)."),
                                      QStringLiteral("S"), QStringLiteral("0.5"));
  parser.addOptions({modelOpt, shotOpt, sizeOpt, windowOpt, wireOpt, dbOpt, noPhysicsOpt, physicsOpt, pushOpt, cutOpt,
                     dragOpt, simTimeOpt, zoomOpt, orbitOpt, scalpelOpt, cutSpeedOpt, cutLiveOpt});
  if (!parser.parse(QApplication::arguments())) {
    printError(parser.errorText());
    return kBadInput;
  }
  if (parser.isSet(QStringLiteral("help"))) parser.showHelp(0);
  if (parser.isSet(QStringLiteral("version"))) parser.showVersion();
  if (!parser.positionalArguments().isEmpty()) {
    printError(QStringLiteral("unexpected argument '%1'").arg(parser.positionalArguments().first()));
    return kBadInput;
  }

  QString model = parser.value(modelOpt);
  if (model.isEmpty()) model = ld::gui::defaultModelPath();

  const bool shot = parser.isSet(shotOpt);
  const bool physics = shot ? parser.isSet(physicsOpt) : !parser.isSet(noPhysicsOpt);
  if (physics && shot && !ld::gui::MainWindow::physicsAvailable()) {
    printError(QStringLiteral("--physics: this build has no physics module (ld_sim_physics with ld_sim_io)"));
    return kBadInput;
  }
  std::array<double, 6> push{};
  const bool hasPush = parser.isSet(pushOpt);
  if (hasPush) {
    const QStringList parts = parser.value(pushOpt).split(',');
    bool ok = parts.size() == 6;
    for (int i = 0; ok && i < 6; ++i) push[static_cast<std::size_t>(i)] = parts[i].toDouble(&ok);
    if (!ok || !physics) {
      printError(QStringLiteral("--push: expected X,Y,Z,FX,FY,FZ (six numbers) together with --physics"));
      return kBadInput;
    }
  }
  std::vector<Stroke> strokes;
  for (const QString& value : parser.values(cutOpt)) {
    const auto stroke = parseStroke(value);
    if (!stroke || !physics) {
      printError(QStringLiteral("--cut: '%1' is not X0,Y0,X1,Y1[,...]:DEPTH (X,Y pairs, DEPTH > 0 mm) or "
                                "X0,Y0,X1,Y1,DEPTH, together with --physics")
                     .arg(value));
      return kBadInput;
    }
    strokes.push_back(*stroke);
  }
  bool cutSpeedOk = false;
  const double cutSpeed = parser.value(cutSpeedOpt).toDouble(&cutSpeedOk);
  if (!cutSpeedOk || !(cutSpeed >= 0.0) || cutSpeed > 10000.0 || (parser.isSet(cutSpeedOpt) && strokes.empty())) {
    printError(QStringLiteral("--cut-speed: '%1' is not a speed in [0, 10000] mm/s given with --cut")
                   .arg(parser.value(cutSpeedOpt)));
    return kBadInput;
  }
  std::optional<QVector3D> drag;
  if (parser.isSet(dragOpt)) {
    const auto d = numbers(parser.value(dragOpt));
    if (!d || d->size() != 3 || strokes.empty()) {
      printError(QStringLiteral("--drag-piece: expected DX,DY,DZ (three numbers) together with --cut"));
      return kBadInput;
    }
    drag = QVector3D(static_cast<float>((*d)[0]), static_cast<float>((*d)[1]), static_cast<float>((*d)[2]));
  }
  std::optional<std::pair<float, float>> orbit;
  if (parser.isSet(orbitOpt)) {
    const auto o = numbers(parser.value(orbitOpt));
    if (!o || o->size() != 2 || std::abs((*o)[1]) > 89.0) {
      printError(QStringLiteral("--orbit: expected YAW,PITCH in degrees (pitch within +-89)"));
      return kBadInput;
    }
    orbit = std::pair{static_cast<float>((*o)[0]), static_cast<float>((*o)[1])};
  }
  bool simTimeOk = false;
  const double simTime = parser.value(simTimeOpt).toDouble(&simTimeOk);
  if (!simTimeOk || !(simTime >= 0.0) || simTime > 60.0) {
    printError(QStringLiteral("--sim-time: '%1' is not a number of seconds in [0, 60]").arg(parser.value(simTimeOpt)));
    return kBadInput;
  }

  if (parser.isSet(cutLiveOpt) && strokes.empty()) {
    printError(QStringLiteral("--cut-live: only together with --cut"));
    return kBadInput;
  }
  ld::gui::MainWindow window;
  window.setHoldWhileCutting(!parser.isSet(cutLiveOpt));
  window.setDatabaseUrl(parser.value(dbOpt));
  window.view()->setWireframe(parser.isSet(wireOpt));
  window.setPhysicsEnabled(physics);

  if (parser.isSet(shotOpt)) {
    static const QRegularExpression sizeRe(QStringLiteral("^(\\d+)x(\\d+)$"));
    const auto m = sizeRe.match(parser.value(sizeOpt));
    const int w = m.hasMatch() ? m.captured(1).toInt() : 0, h = m.hasMatch() ? m.captured(2).toInt() : 0;
    if (w < 64 || h < 64 || w > 8192 || h > 8192) {
      printError(QStringLiteral("--size: '%1' is not WxH between 64 and 8192").arg(parser.value(sizeOpt)));
      return kBadInput;
    }
    if (model.isEmpty()) {
      printError(QStringLiteral("no --model given and the bundled models were not found"));
      return kBadInput;
    }
    try {
      window.loadModelNow(model);
    } catch (const std::exception& e) {
      printError(QString::fromUtf8(e.what()));
      return kBadInput;
    }
    if (parser.isSet(dbOpt)) window.openStore();  // a first start creates it; failures only show
    window.view()->setFixedSize(w, h);
    window.show();
    if (orbit) window.view()->camera().setOrientation(orbit->first, orbit->second);
    window.view()->fitToView();  // the view has its final size only now
    bool zoomOk = false;
    const double zoom = parser.value(zoomOpt).toDouble(&zoomOk);
    if (!zoomOk || std::abs(zoom) > 40) {
      printError(QStringLiteral("--zoom: '%1' is not a number of steps in [-40, 40]").arg(parser.value(zoomOpt)));
      return kBadInput;
    }
    window.view()->camera().zoom(static_cast<float>(zoom));
    const QString out = parser.value(shotOpt);
    int rc = 0;
    auto take = [&] {
      const QImage image = parser.isSet(windowOpt) ? window.grab().toImage() : window.view()->grabFramebuffer();
      if (image.isNull() || !image.save(out, "PNG")) {
        printError(QStringLiteral("%1:0: cannot write the screenshot").arg(out));
        rc = 1;
      } else {
        std::printf("%s\n", qPrintable(window.view()->rendererInfo()));
      }
      QApplication::quit();
    };
    if (!physics) {
      QTimer::singleShot(0, &window, take);
      return std::max(rc, QApplication::exec());
    }
#ifdef LD_GUI_HAVE_PHYSICS
    // Poll until the tissue has settled and then run --sim-time more simulated seconds.
    QElapsedTimer wall;
    wall.start();
    double startTime = -1.0;
    std::optional<std::size_t> pushed;
    std::size_t cutObjects = 1;
    ld::gui::Vec3f pushedFrom{};
    QTimer poll;
    QObject::connect(&poll, &QTimer::timeout, &window, [&] {
      ld::gui::PhysicsSession* session = window.physics();
      if (!session) {
        printError(QStringLiteral("the simulation did not start"));
        rc = 1;
        QApplication::quit();
        return;
      }
      if (wall.elapsed() > 120000) {
        printError(QStringLiteral("the simulation did not reach the requested time within 120 s"));
        rc = 1;
        QApplication::quit();
        return;
      }
      if (!session->settled()) return;
      if (startTime < 0) {
        startTime = session->simTime();
        if (hasPush) {
          session->forceAt(Eigen::Vector3d(push[0], push[1], push[2]), Eigen::Vector3d(push[3], push[4], push[5]));
          window.pollPhysics();
          pushed = nearestVertex(window.view()->mesh(), push);
          if (pushed) pushedFrom = window.view()->mesh().positions[*pushed];
        }
        for (const Stroke& s : strokes)
          if (!window.cutStroke(s.points, s.depth, cutSpeed)) {
            printError(QStringLiteral("--cut: this build has no cutting module (ld_sim_cutting)"));
            rc = kBadInput;
            QApplication::quit();
            return;
          }
        if (!strokes.empty()) {
          window.syncPhysics();  // the cuts are made: the pieces exist
          cutObjects = window.objectCount();
          if (drag) window.dragPieces(*drag, true);
          if (parser.isSet(scalpelOpt)) {
            const Stroke& last = strokes.back();
            const QPointF a = last.points[last.points.size() - 2], b = last.points.back();
            const float z = window.view()->mesh().bounds().max[2];
            ld::gui::ScalpelPose pose;
            pose.dir = QVector3D(0, 0, -1);
            pose.tip =
                QVector3D(static_cast<float>(b.x()), static_cast<float>(b.y()), z - static_cast<float>(last.depth));
            pose.up = QVector3D(static_cast<float>(b.x() - a.x()), static_cast<float>(b.y() - a.y()), 0).normalized();
            window.view()->setScalpel(pose);
          }
        }
        return;
      }
      if (session->simTime() < startTime + simTime) return;
      poll.stop();
      window.pollPhysics();
      window.showPhysicsStatus();  // the status line as of this frame, for the screenshot
      if (drag) {  // frame the moved pieces too
        window.view()->fitToView();
        window.view()->camera().zoom(static_cast<float>(zoom));
      }
      const ld::gui::RenderMesh& shown = window.view()->mesh();
      const ld::gui::Bounds b = shown.bounds();
      std::size_t wallTriangles = 0, vertices = 0, triangles = 0;
      for (const auto& o : window.view()->objects()) {
        vertices += o.positions.size();
        triangles += o.triangles.size();
      }
      for (const auto& o : window.view()->objects())
        wallTriangles += static_cast<std::size_t>(
            std::count_if(o.faceKind.begin(), o.faceKind.end(), [](auto k) { return k != 0; }));
      // How far the pushed vertex moved since the force was applied [mm].
      std::array<double, 3> moved{0, 0, 0};
      if (pushed)
        for (std::size_t a = 0; a < 3; ++a)
          moved[a] = static_cast<double>(shown.positions[*pushed][a]) - static_cast<double>(pushedFrom[a]);
      const auto st = session->stats();
      std::printf(
          "{\"step_us_mean\":%.1f,\"step_us_max\":%.1f,\"steps\":%llu,\"late_steps\":%llu,\"nan_frames\":%llu,"
          "\"stability_warnings\":%llu,",
          st.meanStepUs, st.maxStepUs, static_cast<unsigned long long>(st.steps),
          static_cast<unsigned long long>(st.late), static_cast<unsigned long long>(st.nanFrames),
          static_cast<unsigned long long>(st.warnings));
      std::printf(
          "\"settled\":true,\"settle_sim_time_s\":%.4f,\"sim_time_s\":%.4f,\"min_z\":%.4f,\"max_z\":%.4f,"
          "\"pushed_displacement\":[%.4f,%.4f,%.4f],\"vertices\":%zu,\"triangles\":%zu,\"cut_wall_triangles\":%zu,"
          "\"triangles_cut\":%ld,\"objects\":%zu,\"objects_after_cuts\":%zu,\"status\":\"%s\"}\n",
          startTime, session->simTime(), static_cast<double>(b.min[2]), static_cast<double>(b.max[2]), moved[0],
          moved[1], moved[2], vertices, triangles, wallTriangles, session->trianglesCut(), window.objectCount(),
          cutObjects, qPrintable(session->status()));
      take();
    });
    poll.start(10);
    return std::max(rc, QApplication::exec());
#endif
  }

  window.resize(1280, 860);
  window.show();
  window.openStore();  // creates the store on a first start; a failure is only reported
  if (!model.isEmpty())
    window.loadModelInBackground(model);
  else
    printError(QStringLiteral("the bundled models (resources/models) were not found; use File > Open"));
  return QApplication::exec();
}
