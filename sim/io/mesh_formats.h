#pragma once
// Lower layer of the importers: every parser turns bytes into a RawMesh (points and
// polygons, as the file states them); process() triangulates, cleans and orients it
// into a TriangleSoup; buildMesh() turns the soup into a SurfaceMesh. The parsers take
// in-memory buffers so that fuzzers and tests need no files.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "sim/io/mesh_io.h"

namespace ld::io {

enum class Format { Vrml, Obj, Stl, Ply, Off };

// By extension, case-insensitive (.wrl .vrml .obj .stl .ply .off); nullopt otherwise.
std::optional<Format> formatFromPath(const std::filesystem::path& file);
const char* formatName(Format f);

// Polygons as the file gives them: polygon i uses indices[start[i] .. start[i+1]).
struct RawMesh {
  std::vector<Eigen::Vector3d> points;
  std::vector<std::uint32_t> indices;
  std::vector<std::uint32_t> start{0};
  std::vector<long> line;  // source line per polygon (0 where unknown)
  bool weld = false;       // the format repeats shared corners (STL): merge equal points
  std::string source;      // file name for messages

  [[nodiscard]] std::size_t polygonCount() const { return start.size() - 1; }
  void addPolygon(const std::uint32_t* idx, std::size_t n, long srcLine) {
    indices.insert(indices.end(), idx, idx + n);
    start.push_back(static_cast<std::uint32_t>(indices.size()));
    line.push_back(srcLine);
  }
};

// All parsers throw ParseError("name:line: reason") on malformed input and append
// warnings (skipped nodes, lenient reading) to `report` when given.
RawMesh parseVrml(std::string_view text, const std::string& name, ImportReport* report = nullptr);
RawMesh parseObj(std::string_view text, const std::string& name, ImportReport* report = nullptr);
RawMesh parseStl(std::string_view data, const std::string& name, ImportReport* report = nullptr);
RawMesh parsePly(std::string_view data, const std::string& name, ImportReport* report = nullptr);
RawMesh parseOff(std::string_view text, const std::string& name, ImportReport* report = nullptr);
RawMesh parse(Format f, std::string_view data, const std::string& name, ImportReport* report = nullptr);

using Triangle = std::array<std::uint32_t, 3>;

struct TriangleSoup {
  std::vector<Eigen::Vector3d> points;
  std::vector<Triangle> triangles;
  std::string source;  // file name for messages
};

// Splits polygons into triangles. Quads and larger polygons are cut along diagonals
// that are not already edges of the mesh (a diagonal that exists elsewhere would give
// that edge a third and fourth face), choosing ears of the projected polygon.
// Polygons with fewer than three distinct corners are dropped and counted.
TriangleSoup triangulate(const RawMesh& raw, ImportReport* report = nullptr);

// Cleans a soup in place: welds equal points when `weld`, drops faces that repeat a
// vertex, drops unreferenced vertices, orients each edge-connected piece consistently
// (outward when closed). Zero-area faces are kept and counted (see ImportReport).
void cleanSoup(TriangleSoup& soup, bool weld, ImportReport* report = nullptr);

// Facts about a soup, computed on the soup itself so that non-manifold input is
// reported as such even though the SurfaceMesh cannot hold it.
struct MeshStats {
  std::size_t vertices = 0, triangles = 0, edges = 0, boundaryEdges = 0, nonManifoldEdges = 0;
  std::size_t nonManifoldVertices = 0, degenerateFaces = 0, components = 0;
  bool manifold = true, closed = false, consistentlyOriented = true;
  long euler = 0;
  double area = 0.0;
  Eigen::Vector3d bboxMin = Eigen::Vector3d::Zero(), bboxMax = Eigen::Vector3d::Zero();
};
MeshStats computeStats(const TriangleSoup& soup);

// Builds the mesh. Zero-area faces are left out (the mesh forbids them); a face that
// would make an edge non-manifold gets copies of its vertices instead (warned).
mesh::SurfaceMesh buildMesh(const TriangleSoup& soup, ImportReport* report = nullptr);

// Reads and processes a file or buffer up to the soup (what `mesh info` reports on).
TriangleSoup readSoup(const std::filesystem::path& file, const ReadOptions& options = {},
                      ImportReport* report = nullptr);
TriangleSoup parseSoup(Format f, std::string_view data, const std::string& name, const ReadOptions& options = {},
                       ImportReport* report = nullptr);

// Whole file as bytes; throws IoError when it cannot be read.
std::string readFileBytes(const std::filesystem::path& file);

}  // namespace ld::io
