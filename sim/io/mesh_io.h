#pragma once
// Model import and export. Formats by extension: .wrl/.vrml (VRML 1.0 and 2.0/97),
// .obj, .stl (ASCII and binary), .ply (ASCII and binary), .off. Export: .obj, .ply, .wrl.
// This header is the contract other modules use; the io module fills in details.
#include <filesystem>
#include <string>
#include <vector>

#include "sim/io/io_error.h"
#include "sim/mesh/surface_mesh.h"

namespace ld::io {

struct ImportReport {
  std::vector<std::string> warnings;  // "file:line: reason" where a place is known
};

// Reads a model into a surface mesh (triangulated, welded where the format needs it,
// unreferenced vertices dropped, orientation made consistent). Throws ParseError
// ("file:line: reason") on malformed input.
mesh::SurfaceMesh readMesh(const std::filesystem::path& file, ImportReport* report = nullptr);

// Writes by extension (.obj, .ply, .wrl). Throws IoError on failure.
void writeMesh(const mesh::SurfaceMesh& m, const std::filesystem::path& file);

}  // namespace ld::io
