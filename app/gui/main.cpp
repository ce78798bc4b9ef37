// lapdissect: the desktop program.
//   lapdissect [--model FILE] [--db URL] [--wireframe] [--no-physics]
//              [--screenshot OUT.png [--size WxH] [--whole-window]
//               [--physics [--push X,Y,Z,FX,FY,FZ] [--cut X0,Y0,X1,Y1,DEPTH] [--sim-time S]]]
// With --physics the screenshot is taken after the tissue has settled and run for
// --sim-time simulated seconds (with the --push force at the vertex nearest X,Y,Z,
// and a scalpel stroke across the top from (X0,Y0) to (X1,Y1) DEPTH mm deep);
// a JSON line with the simulation's figures goes to stdout.
// With --screenshot it renders one frame of the model to OUT.png and exits
// (0 on success, 2 on bad input, 1 when rendering or writing fails).
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

}  // namespace

int main(int argc, char** argv) {
  QSurfaceFormat format;
  format.setVersion(3, 3);
  format.setProfile(QSurfaceFormat::CoreProfile);
  format.setDepthBufferSize(24);
  format.setSamples(4);
  QSurfaceFormat::setDefaultFormat(format);

  QApplication app(argc, argv);
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
  const QCommandLineOption cutOpt(QStringLiteral("cut"),
                                  QStringLiteral("With --physics: a scalpel stroke across the top, DEPTH mm deep."),
                                  QStringLiteral("X0,Y0,X1,Y1,DEPTH"));
  const QCommandLineOption simTimeOpt(QStringLiteral("sim-time"),
                                      QStringLiteral("With --physics: simulated seconds after settling (default 0.5)."),
                                      QStringLiteral("S"), QStringLiteral("0.5"));
  parser.addOptions({modelOpt, shotOpt, sizeOpt, windowOpt, wireOpt, dbOpt, noPhysicsOpt, physicsOpt, pushOpt, cutOpt,
                     simTimeOpt, zoomOpt});
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
  std::array<double, 5> cut{};
  const bool hasCut = parser.isSet(cutOpt);
  if (hasCut) {
    const QStringList parts = parser.value(cutOpt).split(',');
    bool ok = parts.size() == 5;
    for (int i = 0; ok && i < 5; ++i) cut[static_cast<std::size_t>(i)] = parts[i].toDouble(&ok);
    if (!ok || !physics || !(cut[4] > 0.0)) {
      printError(QStringLiteral("--cut: expected X0,Y0,X1,Y1,DEPTH (five numbers, DEPTH > 0) together with --physics"));
      return kBadInput;
    }
  }
  bool simTimeOk = false;
  const double simTime = parser.value(simTimeOpt).toDouble(&simTimeOk);
  if (!simTimeOk || !(simTime >= 0.0) || simTime > 60.0) {
    printError(QStringLiteral("--sim-time: '%1' is not a number of seconds in [0, 60]").arg(parser.value(simTimeOpt)));
    return kBadInput;
  }

  ld::gui::MainWindow window;
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
        if (hasCut && !window.cutAcrossTop(cut[0], cut[1], cut[2], cut[3], cut[4])) {
          printError(QStringLiteral("--cut: this build has no cutting module (ld_sim_cutting)"));
          rc = kBadInput;
          QApplication::quit();
        }
        return;
      }
      if (session->simTime() < startTime + simTime) return;
      poll.stop();
      window.pollPhysics();
      const ld::gui::RenderMesh& shown = window.view()->mesh();
      const ld::gui::Bounds b = shown.bounds();
      // How far the pushed vertex moved since the force was applied [mm].
      std::array<double, 3> moved{0, 0, 0};
      if (pushed)
        for (std::size_t a = 0; a < 3; ++a)
          moved[a] = static_cast<double>(shown.positions[*pushed][a]) - static_cast<double>(pushedFrom[a]);
      std::printf(
          "{\"settled\":true,\"settle_sim_time_s\":%.4f,\"sim_time_s\":%.4f,\"min_z\":%.4f,\"max_z\":%.4f,"
          "\"pushed_displacement\":[%.4f,%.4f,%.4f],\"vertices\":%zu,\"triangles\":%zu,\"cut_wall_triangles\":%zu,"
          "\"triangles_cut\":%ld,\"status\":\"%s\"}\n",
          startTime, session->simTime(), static_cast<double>(b.min[2]), static_cast<double>(b.max[2]), moved[0],
          moved[1], moved[2], shown.positions.size(), shown.triangles.size(),
          static_cast<std::size_t>(
              std::count_if(shown.faceKind.begin(), shown.faceKind.end(), [](auto k) { return k != 0; })),
          session->trianglesCut(), qPrintable(session->status()));
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
