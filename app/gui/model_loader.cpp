#include "app/gui/model_loader.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#ifdef LD_GUI_HAVE_SIM_IO
#include "sim/io/mesh_io.h"
#endif

namespace ld::gui {
namespace {

[[noreturn]] void fail(const std::filesystem::path& file, long line, const std::string& reason) {
  throw ModelLoadError(file.string() + ":" + std::to_string(line) + ": " + reason);
}

}  // namespace

#ifdef LD_GUI_HAVE_SIM_IO
RenderMesh renderMeshFrom(const mesh::SurfaceMesh& sm) {
  RenderMesh r;
  std::vector<std::uint32_t> index(sm.verticesSize(), 0);
  for (auto v : sm.vertices()) {
    index[v.idx()] = static_cast<std::uint32_t>(r.positions.size());
    const auto& p = sm.position(v);
    r.positions.push_back({static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())});
  }
  r.triangles.reserve(sm.nFaces());
  for (auto f : sm.faces()) {
    const auto& vs = sm.vertices(f);
    r.triangles.push_back({index[vs[0].idx()], index[vs[1].idx()], index[vs[2].idx()]});
  }
  return r;
}
#endif

RenderMesh readObjForDisplay(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(file, 0, "cannot open file");
  RenderMesh m;
  std::string line;
  long lineNo = 0;
  std::vector<std::uint32_t> poly;
  while (std::getline(in, line)) {
    ++lineNo;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ss(line);
    std::string tag;
    if (!(ss >> tag)) continue;
    if (tag == "v") {
      double x = 0, y = 0, z = 0;
      if (!(ss >> x >> y >> z)) fail(file, lineNo, "vertex needs three numbers");
      if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
        fail(file, lineNo, "vertex coordinate is not finite");
      m.positions.push_back({static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)});
    } else if (tag == "f") {
      poly.clear();
      std::string word;
      while (ss >> word) {
        long i = 0;
        const auto slash = word.find('/');
        const std::string head = word.substr(0, slash);
        const auto [ptr, ec] = std::from_chars(head.data(), head.data() + head.size(), i);
        if (ec != std::errc() || ptr != head.data() + head.size() || i == 0)
          fail(file, lineNo, "bad face index '" + word + "'");
        const long n = static_cast<long>(m.positions.size());
        const long k = i > 0 ? i - 1 : n + i;
        if (k < 0 || k >= n) fail(file, lineNo, "face index " + std::to_string(i) + " out of range");
        poly.push_back(static_cast<std::uint32_t>(k));
      }
      if (poly.size() < 3) fail(file, lineNo, "face has fewer than three corners");
      for (std::size_t c = 1; c + 1 < poly.size(); ++c) m.triangles.push_back({poly[0], poly[c], poly[c + 1]});
    }
  }
  if (m.triangles.empty()) fail(file, lineNo, "no faces");
  return m;
}

LoadedModel loadModel(const std::filesystem::path& file) {
  LoadedModel out;
  out.file = file;
  if (!std::filesystem::exists(file)) fail(file, 0, "no such file");
#ifdef LD_GUI_HAVE_SIM_IO
  try {
    io::ImportReport report;
    mesh::SurfaceMesh sm = io::readMesh(file, &report);
    out.mesh = renderMeshFrom(sm);
    out.surface = std::move(sm);
    out.warnings = std::move(report.warnings);
  } catch (const io::ParseError& e) {
    throw ModelLoadError(e.what());
  } catch (const io::IoError& e) {
    throw ModelLoadError(e.what());
  } catch (const std::exception& e) {
    fail(file, 0, e.what());
  }
  if (out.mesh.empty()) fail(file, 0, "the model has no triangles");
#else
  auto ext = file.extension().string();
  for (auto& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  if (ext != ".obj") fail(file, 0, "this build reads OBJ only (the importers, ld_sim_io, were not built)");
  out.mesh = readObjForDisplay(file);
#endif
  return out;
}

QString modelFileFilter() {
#ifdef LD_GUI_HAVE_SIM_IO
  return QStringLiteral("Models (*.obj *.wrl *.vrml *.stl *.ply *.off);;All files (*)");
#else
  return QStringLiteral("OBJ models (*.obj);;All files (*)");
#endif
}

}  // namespace ld::gui
