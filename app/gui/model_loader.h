#pragma once
// Loading a model file for display. With the project's importers (ld_sim_io) every
// format DESIGN.md lists is read through ld::io::readMesh; without them only OBJ is
// read, by a small reader here. Errors are ModelLoadError with "file:line: reason".
#include <QString>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "app/gui/render_mesh.h"
#ifdef LD_GUI_HAVE_SIM_IO
#include "sim/mesh/surface_mesh.h"
#endif

namespace ld::gui {

class ModelLoadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct LoadedModel {
  RenderMesh mesh;
  std::vector<std::string> warnings;
  std::filesystem::path file;
#ifdef LD_GUI_HAVE_SIM_IO
  std::optional<mesh::SurfaceMesh> surface;  // what the importers built (for the simulation)
#endif
};

// Safe to call from a worker thread.
LoadedModel loadModel(const std::filesystem::path& file);

// The reader used when ld_sim_io is absent (and by the tests): v and f records only;
// polygons are fanned into triangles, negative (relative) indices allowed.
RenderMesh readObjForDisplay(const std::filesystem::path& file);

#ifdef LD_GUI_HAVE_SIM_IO
// The live vertices and faces of a surface mesh, renumbered compactly.
RenderMesh renderMeshFrom(const mesh::SurfaceMesh& sm);
#endif

// Name filter for the Open dialog.
QString modelFileFilter();

}  // namespace ld::gui
