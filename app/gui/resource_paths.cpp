#include "app/gui/resource_paths.h"

#include <QCoreApplication>
#include <QDir>
#include <QFileInfo>
#include <QStringList>

namespace ld::gui {

QString findResourcesDir() {
  QStringList candidates;
  const QString env = qEnvironmentVariable("LD_RESOURCES");
  if (!env.isEmpty()) candidates << env;
  const QString bin = QCoreApplication::applicationDirPath();
  if (!bin.isEmpty())
    candidates << bin + "/resources" << bin + "/../resources" << bin + "/../share/lapdissect/resources";
#ifdef LD_GUI_RESOURCES_DIR
  candidates << QStringLiteral(LD_GUI_RESOURCES_DIR);
#endif
  for (const QString& c : candidates)
    if (QFileInfo::exists(c + "/models/tissue_slab.obj")) return QDir(c).canonicalPath();
  return {};
}

QString defaultModelPath() {
  const QString dir = findResourcesDir();
  return dir.isEmpty() ? QString() : dir + "/models/tissue_slab.obj";
}

}  // namespace ld::gui
