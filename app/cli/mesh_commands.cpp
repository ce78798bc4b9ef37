// lapdissect-cli mesh info FILE | mesh convert IN OUT   (contract in DESIGN.md)
// Both take `--weld on` to merge equal points in every format (STL always is);
// convert takes `--binary on` to write binary PLY.
// Extension: mesh slab --triangles N --out FILE writes the default tissue's box
// (tissue_slab.obj's 80 x 60 x 5 mm, centred on the origin) at the resolution that
// gives about N triangles, so that the scripted tasks' trajectories cut it: the
// command line's figures at the targets' 100k triangles.
#include <cmath>
#include <string>

#include "app/cli/cli.h"
#include "sim/io/mesh_formats.h"
#include "sim/io/mesh_io.h"
#include "sim/physics/scenes.h"

namespace ld::cli {
namespace {

io::ReadOptions readOptions(const Args& args) {
  const std::string w = args.get("weld", "off");
  if (w != "on" && w != "off") throw CliError(kBadInput, "option --weld: expected 'on' or 'off', found '" + w + "'");
  return io::ReadOptions{w == "on"};
}

nlohmann::json vec(const Eigen::Vector3d& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); }

int info(const Args& args) {
  const std::string file = args.pos(1, "FILE (mesh info FILE)");
  io::ImportReport rep;
  // Facts come from the processed soup, not from the SurfaceMesh, so that what the
  // mesh cannot hold (edges with three faces) is still reported.
  const io::TriangleSoup soup = io::readSoup(file, readOptions(args), &rep);
  const io::MeshStats st = io::computeStats(soup);
  nlohmann::json j;
  j["file"] = file;
  j["format"] = rep.format;
  if (rep.vrmlVersion) j["vrml_version"] = rep.vrmlVersion;
  j["vertices"] = st.vertices;
  j["triangles"] = st.triangles;
  j["edges"] = st.edges;
  j["boundary_edges"] = st.boundaryEdges;
  j["components"] = st.components;
  j["manifold"] = st.manifold;
  j["closed"] = st.closed;
  j["area"] = st.area;
  j["bbox"] = nlohmann::json::array({vec(st.bboxMin), vec(st.bboxMax)});
  j["non_manifold_edges"] = st.nonManifoldEdges;
  j["non_manifold_vertices"] = st.nonManifoldVertices;
  j["degenerate_faces"] = st.degenerateFaces;
  j["consistently_oriented"] = st.consistentlyOriented;
  j["euler"] = st.euler;
  // Genus summed over components; defined for closed manifold surfaces only.
  if (st.closed && st.manifold) j["genus"] = (2 * static_cast<long>(st.components) - st.euler) / 2;
  j["welded_vertices"] = rep.weldedVertices;
  j["dropped_vertices"] = rep.droppedVertices;
  j["dropped_faces"] = rep.droppedPolygons;
  j["flipped_faces"] = rep.flippedFaces;
  j["warnings"] = rep.warnings;
  printJson(j);
  return kOk;
}

int convert(const Args& args) {
  const std::string in = args.pos(1, "IN (mesh convert IN OUT)");
  const std::string out = args.pos(2, "OUT (mesh convert IN OUT)");
  const auto outFormat = io::formatFromPath(out);
  if (!outFormat || *outFormat == io::Format::Stl || *outFormat == io::Format::Off)
    throw CliError(kBadInput, out + ": cannot export this format (use .obj, .ply or .wrl)");
  io::ImportReport rep;
  const mesh::SurfaceMesh m = io::readMesh(in, readOptions(args), &rep);
  const std::string binary = args.get("binary", "off");
  if (binary != "on" && binary != "off")
    throw CliError(kBadInput, "option --binary: expected 'on' or 'off', found '" + binary + "'");
  io::writeMesh(m, out, io::WriteOptions{binary == "on"});
  nlohmann::json j;
  j["in"] = in;
  j["out"] = out;
  j["vertices"] = m.nVertices();
  j["triangles"] = m.nFaces();
  j["degenerate_faces_left_out"] = rep.degenerateFaces;
  j["duplicated_vertices"] = rep.duplicatedVertices;
  j["warnings"] = rep.warnings;
  printJson(j);
  return kOk;
}

int slab(const Args& args) {
  const std::string out = args.get("out");
  const double wanted = args.getDouble("triangles");
  // A closed box of area A in squares of side h has about 2 A / h^2 triangles.
  constexpr double kX = 80.0, kY = 60.0, kZ = 5.0, kArea = 2.0 * (kX * kY + kX * kZ + kY * kZ);
  constexpr double kMaxTriangles = 2e7;  // gigabytes of mesh already
  if (!(wanted >= 100.0) || wanted > kMaxTriangles)
    throw CliError(kBadInput, "option --triangles: expected 100 to 20000000, found " + args.get("triangles"));
  const auto outFormat = io::formatFromPath(out);
  if (!outFormat || *outFormat == io::Format::Stl || *outFormat == io::Format::Off)
    throw CliError(kBadInput, out + ": cannot export this format (use .obj, .ply or .wrl)");
  const double h = std::sqrt(2.0 * kArea / wanted);
  mesh::SurfaceMesh m = physics::makeSlab(kX, kY, kZ, h);
  for (Eigen::Vector3d& p : m.positions()) p -= Eigen::Vector3d(kX / 2, kY / 2, kZ / 2);
  io::writeMesh(m, out);
  nlohmann::json j;
  j["out"] = out;
  j["vertices"] = m.nVertices();
  j["triangles"] = m.nFaces();
  j["spacing"] = h;
  printJson(j);
  return kOk;
}

}  // namespace

int runMesh(const Args& args) {
  const std::string sub = args.pos(0, "mesh command (info, convert or slab)");
  try {
    if (sub == "info") return info(args);
    if (sub == "convert") return convert(args);
    if (sub == "slab") return slab(args);
  } catch (const io::ParseError& e) {
    throw CliError(kBadInput, e.what());
  } catch (const io::IoError& e) {
    throw CliError(kBadInput, e.what());
  }
  throw CliError(kBadInput, "unknown mesh command '" + sub + "' (expected info, convert or slab)");
}

}  // namespace ld::cli
