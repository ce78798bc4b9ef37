#pragma once
// Model import and export. Formats by extension: .wrl/.vrml (VRML 1.0 and 2.0/97),
// .obj, .stl (ASCII and binary), .ply (ASCII and binary), .off. Export: .obj, .ply, .wrl.
// This header is the contract other modules use; the io module fills in details
// (sim/io/mesh_formats.h holds the parsers and the processing steps).
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "sim/io/io_error.h"
#include "sim/mesh/surface_mesh.h"

namespace ld::io {

struct ImportReport {
  std::vector<std::string> warnings;  // "file:line: reason" where a place is known

  // What processing did (filled by readMesh / readSoup).
  std::string format;                  // "vrml", "obj", "stl", "ply", "off"
  int vrmlVersion = 0;                 // 1 or 2 for VRML files
  std::size_t droppedPolygons = 0;     // fewer than three distinct corners
  std::size_t droppedVertices = 0;     // never referenced by a face
  std::size_t weldedVertices = 0;      // merged into an equal point
  std::size_t flippedFaces = 0;        // reversed to make orientation consistent/outward
  std::size_t degenerateFaces = 0;     // zero area (left out of the SurfaceMesh)
  std::size_t duplicatedVertices = 0;  // copies made for faces on non-manifold edges
  std::size_t skippedFaces = 0;        // faces buildMesh could not add
};

struct ReadOptions {
  // Merge vertices with identical coordinates in every format (STL is always welded:
  // the format has no shared vertices). VRML exporters often duplicate seam vertices.
  bool weld = false;
};

// Reads a model into a surface mesh (triangulated, welded where the format needs it,
// unreferenced vertices dropped, orientation made consistent). Throws ParseError
// ("file:line: reason") on malformed input, IoError when the file cannot be read.
mesh::SurfaceMesh readMesh(const std::filesystem::path& file, ImportReport* report = nullptr);
mesh::SurfaceMesh readMesh(const std::filesystem::path& file, const ReadOptions& options,
                           ImportReport* report = nullptr);

struct WriteOptions {
  bool binaryPly = false;  // .ply as binary_little_endian instead of ASCII
};

// Writes by extension (.obj, .ply, .wrl). Throws IoError on failure.
void writeMesh(const mesh::SurfaceMesh& m, const std::filesystem::path& file);
void writeMesh(const mesh::SurfaceMesh& m, const std::filesystem::path& file, const WriteOptions& options);

}  // namespace ld::io
