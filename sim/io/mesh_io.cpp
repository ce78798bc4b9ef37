// Format dispatch and the readMesh entry point.
#include "sim/io/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <sstream>

#include "sim/io/mesh_formats.h"

namespace ld::io {

std::optional<Format> formatFromPath(const std::filesystem::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".wrl" || ext == ".vrml") return Format::Vrml;
  if (ext == ".obj") return Format::Obj;
  if (ext == ".stl") return Format::Stl;
  if (ext == ".ply") return Format::Ply;
  if (ext == ".off") return Format::Off;
  return std::nullopt;
}

const char* formatName(Format f) {
  switch (f) {
    case Format::Vrml:
      return "vrml";
    case Format::Obj:
      return "obj";
    case Format::Stl:
      return "stl";
    case Format::Ply:
      return "ply";
    case Format::Off:
      return "off";
  }
  return "?";
}

std::string readFileBytes(const std::filesystem::path& file) {
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec)) throw IoError(file.string() + ": is a directory");
  std::ifstream in(file, std::ios::binary);
  if (!in) throw IoError(file.string() + ": cannot open for reading");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw IoError(file.string() + ": read error");
  return ss.str();
}

RawMesh parse(Format f, std::string_view data, const std::string& name, ImportReport* report) {
  RawMesh raw;
  switch (f) {
    case Format::Vrml:
      raw = parseVrml(data, name, report);
      break;
    case Format::Obj:
      raw = parseObj(data, name, report);
      break;
    case Format::Stl:
      raw = parseStl(data, name, report);
      break;
    case Format::Ply:
      raw = parsePly(data, name, report);
      break;
    case Format::Off:
      raw = parseOff(data, name, report);
      break;
  }
  raw.source = name;
  return raw;
}

TriangleSoup parseSoup(Format f, std::string_view data, const std::string& name, const ReadOptions& options,
                       ImportReport* report) {
  if (report) report->format = formatName(f);
  const RawMesh raw = parse(f, data, name, report);
  TriangleSoup soup = triangulate(raw, report);
  cleanSoup(soup, raw.weld || options.weld, report);
  return soup;
}

TriangleSoup readSoup(const std::filesystem::path& file, const ReadOptions& options, ImportReport* report) {
  const auto f = formatFromPath(file);
  if (!f)
    throw ParseError(
        file.string(), 0,
        "unknown model format '" + file.extension().string() + "' (expected .wrl, .vrml, .obj, .stl, .ply or .off)");
  const std::string data = readFileBytes(file);
  return parseSoup(*f, data, file.string(), options, report);
}

mesh::SurfaceMesh readMesh(const std::filesystem::path& file, const ReadOptions& options, ImportReport* report) {
  const TriangleSoup soup = readSoup(file, options, report);
  return buildMesh(soup, report);
}

mesh::SurfaceMesh readMesh(const std::filesystem::path& file, ImportReport* report) {
  return readMesh(file, ReadOptions{}, report);
}

}  // namespace ld::io
