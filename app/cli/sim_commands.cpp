// lapdissect-cli sim bench --scene NAME|FILE --method NAME --dt S --duration S [--monitor on|off] [--active on]
// lapdissect-cli sim chart --out DIR
// (contract in DESIGN.md). The charts are drawn with Qt Charts on the offscreen platform.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <QApplication>
#include <QColor>
#include <QFont>
#include <QImage>
#include <QPainter>
#include <QPixmap>
#include <QtCharts/QChart>
#include <QtCharts/QChartView>
#include <QtCharts/QLegendMarker>
#include <QtCharts/QLineSeries>
#include <QtCharts/QLogValueAxis>
#include <QtCharts/QScatterSeries>

#include "app/cli/cli.h"
#include "sim/io/io_error.h"
#include "sim/io/mesh_io.h"
#include "sim/physics/experiments.h"
#include "sim/physics/physics_error.h"

namespace ld::cli {
namespace {

using physics::BenchResult;
using physics::Method;

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

int bench(const Args& args) {
  const std::string sceneArg = args.get("scene");
  const std::string methodArg = args.get("method");
  const double dt = args.getDouble("dt");
  const double duration = args.getDouble("duration");
  const std::string monitorArg = args.get("monitor", "off");
  if (monitorArg != "on" && monitorArg != "off")
    throw CliError(kBadInput, "option --monitor: expected 'on' or 'off', found '" + monitorArg + "'");
  if (!(dt > 0)) throw CliError(kBadInput, "option --dt: must be positive");
  if (!(duration >= dt)) throw CliError(kBadInput, "option --duration: must be at least --dt");
  if (duration / dt > 1e7) throw CliError(kBadInput, "option --duration: more than 10^7 steps of --dt");
  Method method{};
  try {
    method = physics::methodFromName(methodArg);
  } catch (const physics::UnknownNameError& e) {
    throw CliError(kBadInput, std::string("option --method: ") + e.what());
  }
  physics::Scene scene;
  if (physics::isBuiltinScene(sceneArg)) {
    scene = physics::builtinScene(sceneArg);
  } else if (std::filesystem::exists(sceneArg)) {
    try {
      scene = physics::sceneFromMesh(io::readMesh(sceneArg), sceneArg);
    } catch (const io::ParseError& e) {
      throw CliError(kBadInput, e.what());
    } catch (const io::IoError& e) {
      throw CliError(kBadInput, sceneArg + ":0: " + e.what());
    }
    if (scene.initial.mesh.nFaces() == 0) throw CliError(kBadInput, sceneArg + ":0: the model has no triangles");
  } else {
    throw CliError(kBadInput, "option --scene: '" + sceneArg +
                                  "' is neither a built-in scene (oscillator, patch-release, sliver) nor a file");
  }
  const BenchResult r = physics::benchScene(scene, method, dt, duration, monitorArg == "on");
  nlohmann::json j;
  j["method"] = std::string(physics::methodName(method));
  j["dt"] = dt;
  j["steps"] = r.steps;
  j["us_per_step"] = r.usPerStep;
  j["error_rms"] = number(r.errorRms);
  j["error_max"] = number(r.errorMax);
  j["stable"] = r.stable;
  j["scene"] = sceneArg;
  j["duration"] = r.duration;
  j["vertices"] = r.vertices;
  j["triangles"] = r.triangles;
  j["ms_per_simulated_second"] = r.msPerSimulatedSecond();
  j["reference"] = scene.analytic ? "analytic" : "rk4 at dt/64";
  j["monitor"] = monitorArg == "on";
  j["stability_warnings"] = r.warnings;
  if (args.get("active", "off") == "on") {
    // The active-region mode against the full solve (symplectic Euler, a 5 mN push).
    const auto a = physics::compareActiveRegion(scene, dt, duration);
    j["active"] = {{"work_fraction", a.workFraction},
                   {"max_difference_mm", a.maxDifference},
                   {"us_per_step_full", a.usPerStepFull},
                   {"us_per_step_active", a.usPerStepActive},
                   {"steps", a.steps}};
  }
  printJson(j);
  return kOk;
}

// ---- charts --------------------------------------------------------------------

QColor methodColor(Method m) {
  switch (m) {
    case Method::ExplicitEuler:
      return QColor(214, 39, 40);
    case Method::SymplecticEuler:
      return QColor(31, 119, 180);
    case Method::Verlet:
      return QColor(44, 160, 44);
    case Method::Rk4:
      return QColor(148, 103, 189);
    case Method::ImplicitEuler:
      return QColor(255, 127, 14);
    case Method::Xpbd:
      return QColor(23, 190, 207);
  }
  return Qt::black;
}

struct Point {
  double x, y;
  bool marked;  // unstable (speed-accuracy) or capped (stability)
};

struct Panel {
  QString title, xTitle, yTitle;
  std::map<Method, std::vector<Point>> series;
  QString markLabel;  // legend text for marked points
};

// Draws one log-log panel; marked points sit at the top edge as stars.
QChart* makeChart(const Panel& panel) {
  auto* chart = new QChart();
  chart->setTitle(panel.title);
  QFont tf = chart->titleFont();
  tf.setPointSize(11);
  tf.setBold(true);
  chart->setTitleFont(tf);
  double xmin = std::numeric_limits<double>::infinity(), xmax = 0, ymin = xmin, ymax = 0;
  for (const auto& [m, pts] : panel.series)
    for (const Point& p : pts) {
      xmin = std::min(xmin, p.x);
      xmax = std::max(xmax, p.x);
      if (!p.marked) {
        ymin = std::min(ymin, p.y);
        ymax = std::max(ymax, p.y);
      } else {
        ymax = std::max(ymax, p.y);
      }
    }
  if (!std::isfinite(xmin)) xmin = 1, xmax = 10;
  if (!std::isfinite(ymin)) ymin = 1e-6, ymax = std::max(ymax, 1.0);
  const double xlo = std::pow(10.0, std::floor(std::log10(xmin))), xhi = std::pow(10.0, std::ceil(std::log10(xmax)));
  const double ylo = std::pow(10.0, std::floor(std::log10(ymin))),
               yhi = std::pow(10.0, std::ceil(std::log10(ymax) + 1e-9));
  auto* ax = new QLogValueAxis();
  ax->setTitleText(panel.xTitle);
  ax->setLabelFormat("%g");
  ax->setBase(10);
  ax->setRange(xlo, xhi);
  ax->setMinorTickCount(8);
  auto* ay = new QLogValueAxis();
  ay->setTitleText(panel.yTitle);
  ay->setLabelFormat("%g");
  ay->setBase(10);
  ay->setRange(ylo, yhi);
  chart->addAxis(ax, Qt::AlignBottom);
  chart->addAxis(ay, Qt::AlignLeft);
  bool anyMarked = false;
  for (const auto& [m, pts] : panel.series) {
    const QColor col = methodColor(m);
    auto* line = new QLineSeries();
    line->setName(QString::fromStdString(std::string(physics::methodName(m))));
    QPen pen(col);
    pen.setWidthF(2.0);
    line->setPen(pen);
    auto* dots = new QScatterSeries();
    dots->setColor(col);
    dots->setBorderColor(col);
    dots->setMarkerSize(7);
    auto* marks = new QScatterSeries();
    marks->setMarkerShape(QScatterSeries::MarkerShapeStar);
    marks->setColor(col);
    marks->setBorderColor(col.darker());
    marks->setMarkerSize(14);
    std::vector<Point> sorted = pts;
    std::sort(sorted.begin(), sorted.end(), [](const Point& a, const Point& b) { return a.x < b.x; });
    for (const Point& p : sorted) {
      if (p.marked) {
        marks->append(p.x, std::min(p.y, yhi));
        anyMarked = true;
      } else {
        line->append(p.x, p.y);
        dots->append(p.x, p.y);
      }
    }
    for (QAbstractSeries* s : {static_cast<QAbstractSeries*>(line), static_cast<QAbstractSeries*>(dots),
                               static_cast<QAbstractSeries*>(marks)}) {
      chart->addSeries(s);
      s->attachAxis(ax);
      s->attachAxis(ay);
    }
    for (QLegendMarker* lm : chart->legend()->markers(dots)) lm->setVisible(false);
    for (QLegendMarker* lm : chart->legend()->markers(marks)) lm->setVisible(false);
  }
  if (anyMarked) {
    // One grey star in the legend explains the marked points.
    auto* key = new QScatterSeries();
    key->setName(panel.markLabel);
    key->setMarkerShape(QScatterSeries::MarkerShapeStar);
    key->setColor(Qt::gray);
    key->setMarkerSize(14);
    chart->addSeries(key);
    key->attachAxis(ax);
    key->attachAxis(ay);
  }
  chart->legend()->setAlignment(Qt::AlignBottom);
  QFont lf = chart->legend()->font();
  lf.setPointSize(8);
  chart->legend()->setFont(lf);
  return chart;
}

void savePanels(const std::vector<Panel>& panels, const QString& title, const std::filesystem::path& file) {
  const int w = 720, h = 560, head = 40;
  QImage img(w * static_cast<int>(panels.size()), h + head, QImage::Format_ARGB32);
  img.fill(Qt::white);
  QPainter painter(&img);
  QFont f = painter.font();
  f.setPointSize(13);
  f.setBold(true);
  painter.setFont(f);
  painter.drawText(QRect(0, 0, img.width(), head), Qt::AlignCenter, title);
  for (std::size_t i = 0; i < panels.size(); ++i) {
    QChartView view(makeChart(panels[i]));
    view.setRenderHint(QPainter::Antialiasing);
    view.resize(w, h);
    view.show();
    QApplication::processEvents();
    const QPixmap pm = view.grab();
    painter.drawPixmap(static_cast<int>(i) * w, head, pm);
  }
  painter.end();
  if (!img.save(QString::fromStdString(file.string()))) throw CliError(kInternal, "cannot write " + file.string());
}

int chart(const Args& args) {
  const std::filesystem::path out = args.get("out");
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec || !std::filesystem::is_directory(out))
    throw CliError(kBadInput, "option --out: cannot create directory '" + out.string() + "'");
  const bool verbose = args.get("verbose", "off") == "on";
  auto progress = [&](const std::string& line) {
    if (verbose) std::cerr << line << "\n";
  };

  const auto speed = physics::speedAccuracySweep(progress);
  const auto stab = physics::stabilitySweep(progress);

  {
    std::ofstream csv(out / "speed_accuracy.csv");
    csv << "scene,method,dt_s,steps,us_per_step,ms_per_simulated_second,error_rms_mm,error_max_mm,stable,"
           "vertices,triangles\n";
    for (const BenchResult& r : speed)
      csv << r.scene << "," << physics::methodName(r.method) << "," << r.dt << "," << r.steps << "," << r.usPerStep
          << "," << r.msPerSimulatedSecond() << "," << r.errorRms << "," << r.errorMax << ","
          << (r.stable ? "true" : "false") << "," << r.vertices << "," << r.triangles << "\n";
    if (!csv) throw CliError(kInternal, "cannot write " + (out / "speed_accuracy.csv").string());
  }
  {
    std::ofstream csv(out / "stability.csv");
    csv << "sweep,x,method,largest_stable_dt_s,capped\n";
    for (const auto& r : stab)
      csv << r.sweep << "," << r.x << "," << physics::methodName(r.method) << "," << r.largestStableDt << ","
          << (r.capped ? "true" : "false") << "\n";
    if (!csv) throw CliError(kInternal, "cannot write " + (out / "stability.csv").string());
  }

  // Qt without a display.
  if (qEnvironmentVariableIsEmpty("QT_QPA_PLATFORM")) qputenv("QT_QPA_PLATFORM", "offscreen");
  std::unique_ptr<QApplication> app;
  static int argc = 1;
  static char arg0[] = "lapdissect-cli";
  static char* argv[] = {arg0, nullptr};
  // The offscreen platform warns about window hints it ignores; keep stderr clean.
  if (!verbose)
    qInstallMessageHandler([](QtMsgType type, const QMessageLogContext&, const QString& msg) {
      if (type == QtCriticalMsg || type == QtFatalMsg) std::cerr << msg.toStdString() << "\n";
    });
  if (!QApplication::instance()) app = std::make_unique<QApplication>(argc, argv);

  std::vector<Panel> sa;
  for (const std::string scene : {"oscillator", "patch-release", "sliver"}) {
    Panel p;
    std::size_t tris = 0;
    double yTop = 0;
    for (const BenchResult& r : speed)
      if (r.scene == scene && r.stable) yTop = std::max(yTop, r.errorRms);
    for (const BenchResult& r : speed) {
      if (r.scene != scene) continue;
      tris = r.triangles;
      const double y = r.stable ? std::max(r.errorRms, 1e-12) : std::max(yTop, 1e-12) * 10.0;
      p.series[r.method].push_back({std::max(r.msPerSimulatedSecond(), 1e-6), y, !r.stable});
    }
    p.title = QString::fromStdString(scene) +
              (scene == "oscillator" ? QString(" (vs analytic)") : QString(" (%1 triangles, vs RK4)").arg(tris));
    p.xTitle = "cost: ms of CPU per simulated second";
    p.yTitle = "RMS position error [mm]";
    p.markLabel = "unstable";
    sa.push_back(std::move(p));
  }
  savePanels(sa, "Speed against accuracy: dt from 1/16 ms to 8 ms, one point per dt; stars = unstable runs",
             out / "speed_accuracy.png");

  std::vector<Panel> st(2);
  st[0].title = "Largest stable dt vs spring constant K";
  st[0].xTitle = "K [mN]  (k = K / rest length)";
  st[1].title = "Largest stable dt vs smallest edge";
  st[1].xTitle = "smallest edge length [mm] (sliver column)";
  for (auto& p : st) {
    p.yTitle = "largest stable dt [s]";
    p.markLabel = "stable at 50 ms";
  }
  for (const auto& r : stab) {
    Panel& p = r.sweep == "stiffness" ? st[0] : st[1];
    p.series[r.method].push_back({r.x, r.largestStableDt, r.capped});
  }
  savePanels(st, "Largest stable dt (300 steps, default damping); stars = stable at 50 ms, the largest dt tried",
             out / "stability.png");

  nlohmann::json j;
  j["out"] = out.string();
  j["files"] = {"speed_accuracy.csv", "speed_accuracy.png", "stability.csv", "stability.png"};
  j["speed_accuracy_rows"] = speed.size();
  j["stability_rows"] = stab.size();
  printJson(j);
  return kOk;
}

}  // namespace

int runSim(const Args& args) {
  const std::string& sub = args.pos(0, "sim subcommand (bench or chart)");
  if (sub == "bench") return bench(args);
  if (sub == "chart") return chart(args);
  throw CliError(kBadInput, "unknown sim subcommand '" + sub + "' (bench or chart)");
}

}  // namespace ld::cli
