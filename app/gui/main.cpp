// lapdissect: the desktop program.
//   lapdissect [--model FILE] [--db URL] [--wireframe]
//              [--screenshot OUT.png [--size WxH] [--whole-window]]
// With --screenshot it renders one frame of the model to OUT.png and exits
// (0 on success, 2 on bad input, 1 when rendering or writing fails).
#include <QApplication>
#include <QCommandLineParser>
#include <QImage>
#include <QPixmap>
#include <QRegularExpression>
#include <QSurfaceFormat>
#include <QTimer>

#include <cstdio>

#include "app/gui/main_window.h"
#include "app/gui/mesh_view.h"
#include "app/gui/resource_paths.h"

namespace {

constexpr int kBadInput = 2;

void printError(const QString& s) { std::fprintf(stderr, "lapdissect: %s\n", qPrintable(s)); }

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
  parser.addOptions({modelOpt, shotOpt, sizeOpt, windowOpt, wireOpt, dbOpt});
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

  ld::gui::MainWindow window;
  window.setDatabaseUrl(parser.value(dbOpt));
  window.view()->setWireframe(parser.isSet(wireOpt));

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
    window.view()->setFixedSize(w, h);
    window.show();
    window.view()->fitToView();  // the view has its final size only now
    const QString out = parser.value(shotOpt);
    int rc = 0;
    QTimer::singleShot(0, &window, [&] {
      const QImage image = parser.isSet(windowOpt) ? window.grab().toImage() : window.view()->grabFramebuffer();
      if (image.isNull() || !image.save(out, "PNG")) {
        printError(QStringLiteral("%1:0: cannot write the screenshot").arg(out));
        rc = 1;
      } else {
        std::printf("%s\n", qPrintable(window.view()->rendererInfo()));
      }
      QApplication::quit();
    });
    const int loopRc = QApplication::exec();
    return rc != 0 ? rc : loopRc;
  }

  window.resize(1280, 860);
  window.show();
  if (!model.isEmpty())
    window.loadModelInBackground(model);
  else
    printError(QStringLiteral("the bundled models (resources/models) were not found; use File > Open"));
  return QApplication::exec();
}
