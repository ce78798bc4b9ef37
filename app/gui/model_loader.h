#pragma once
// Loading a model file for display. With the project's importers (ld_sim_io) every
// format DESIGN.md lists is read through ld::io::readMesh; without them only OBJ is
// read, by a small reader here. Errors are ModelLoadError with "file:line: reason".
#include <QString>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "app/gui/render_mesh.h"

namespace ld::gui {

class ModelLoadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct LoadedModel {
  RenderMesh mesh;
  std::vector<std::string> warnings;
  std::filesystem::path file;
};

// Safe to call from a worker thread.
LoadedModel loadModel(const std::filesystem::path& file);

// The reader used when ld_sim_io is absent (and by the tests): v and f records only;
// polygons are fanned into triangles, negative (relative) indices allowed.
RenderMesh readObjForDisplay(const std::filesystem::path& file);

// Name filter for the Open dialog.
QString modelFileFilter();

}  // namespace ld::gui
