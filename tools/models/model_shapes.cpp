#include "tools/models/model_shapes.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <unordered_map>
#include <unordered_set>
#include <utility>

namespace ld::models {
namespace {

constexpr double kPi = 3.14159265358979323846;

Vec3 operator+(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec3 operator-(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 operator*(double s, const Vec3& a) { return {s * a[0], s * a[1], s * a[2]}; }
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }

std::uint32_t idx(std::size_t i) { return static_cast<std::uint32_t>(i); }

// Adds quad q0..q3 (counter-clockwise seen from outside) as two triangles; `flip`
// chooses the other diagonal so neighbouring cells alternate.
void addQuad(TriMesh& m, std::uint32_t q0, std::uint32_t q1, std::uint32_t q2, std::uint32_t q3, bool flip) {
  if (flip) {
    m.triangles.push_back({q0, q1, q3});
    m.triangles.push_back({q1, q2, q3});
  } else {
    m.triangles.push_back({q0, q1, q2});
    m.triangles.push_back({q0, q2, q3});
  }
}

// Joins concentric rings `inner` and `outer` (both counter-clockwise seen from +z,
// starting at angle 0) with triangles facing +z, or -z when `down`.
void joinRings(TriMesh& m, const std::vector<std::uint32_t>& inner, const std::vector<std::uint32_t>& outer,
               bool down) {
  auto emit = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    if (down)
      m.triangles.push_back({a, c, b});
    else
      m.triangles.push_back({a, b, c});
  };
  const std::size_t na = inner.size(), nb = outer.size();
  if (na == 1) {
    for (std::size_t k = 0; k < nb; ++k) emit(inner[0], outer[k], outer[(k + 1) % nb]);
    return;
  }
  std::size_t a = 0, b = 0;
  while (a < na || b < nb) {
    // Advance on the ring whose next point comes first along the ring; on a tie (a
    // hexagon corner) the inner ring goes first, which gives the lattice's triangles.
    const bool outerFirst = (b + 1) * na < (a + 1) * nb;
    if (b < nb && (a >= na || outerFirst)) {
      emit(inner[a % na], outer[b], outer[(b + 1) % nb]);
      ++b;
    } else {
      emit(inner[a], outer[b % nb], inner[(a + 1) % na]);
      ++a;
    }
  }
}

// A cap of `rings` concentric rings at height z; returns the outer ring's indices.
std::vector<std::uint32_t> addCap(TriMesh& m, double radius, double z, int rings, bool down) {
  std::vector<std::uint32_t> prev{idx(m.points.size())};
  m.points.push_back({0.0, 0.0, z});
  for (int i = 1; i <= rings; ++i) {
    const double r = radius * i / rings;
    const int n = 6 * i;
    std::vector<std::uint32_t> ring;
    for (int k = 0; k < n; ++k) {
      // Points spaced evenly along a hexagon, pushed out onto the circle: rings of
      // the hexagonal lattice, whose triangles are near equilateral.
      const int side = k / i, m6 = k % i;
      const double a0 = kPi / 3.0 * side, a1 = kPi / 3.0 * (side + 1);
      const double hx = (std::cos(a0) * (i - m6) + std::cos(a1) * m6) / i;
      const double hy = (std::sin(a0) * (i - m6) + std::sin(a1) * m6) / i;
      const double t = std::atan2(hy, hx);
      ring.push_back(idx(m.points.size()));
      m.points.push_back({r * std::cos(t), r * std::sin(t), z});
    }
    joinRings(m, prev, ring, down);
    prev = std::move(ring);
  }
  return prev;
}

TriMesh makeCapped(double radius, double height, int rings, int layers) {
  TriMesh m;
  const auto bottom = addCap(m, radius, -0.5 * height, rings, true);
  const auto top = addCap(m, radius, 0.5 * height, rings, false);
  const std::size_t n = top.size();
  std::vector<std::uint32_t> lower = bottom;
  for (int l = 1; l <= layers; ++l) {
    std::vector<std::uint32_t> upper;
    if (l == layers) {
      upper = top;
    } else {
      const double z = -0.5 * height + height * l / layers;
      for (std::size_t k = 0; k < n; ++k) {
        const Vec3& onTop = m.points[top[k]];
        upper.push_back(idx(m.points.size()));
        m.points.push_back({onTop[0], onTop[1], z});
      }
    }
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t k1 = (k + 1) % n;
      addQuad(m, lower[k], lower[k1], upper[k1], upper[k], (k + static_cast<std::size_t>(l)) % 2 == 1);
    }
    lower = std::move(upper);
  }
  return m;
}

// ---- organ -------------------------------------------------------------------

// Bumps on the unit sphere; |radial| stays well below 1 so the surface is star-shaped.
double radial(const Vec3& u) {
  return 1.0 + 0.06 * std::sin(3.0 * u[0] + 1.0) * std::cos(2.0 * u[1]) + 0.04 * std::cos(4.0 * u[2] + u[0]);
}
constexpr double kAx = 50.0, kAy = 35.0, kAz = 20.0;
// x-dependent taper and bend; both keep x, so the map stays one-to-one.
double taperY(double x) { return 1.0 - 0.12 * x / kAx; }
double taperZ(double x) { return 1.0 + 0.25 * x / kAx; }
double bendZ(double x) { return 9.0 * (x / kAx) * (x / kAx); }

Vec3 organPoint(const Vec3& dir) {
  const Vec3 u = (1.0 / norm(dir)) * dir;
  const double r = radial(u);
  const double x = kAx * r * u[0];
  const double y = kAy * r * u[1] * taperY(x);
  const double z = kAz * r * u[2] * taperZ(x) + bendZ(x);
  return {x, y, z};
}

// Back to the unit-sphere direction of a point near the surface, then onto it.
Vec3 projectOrgan(const Vec3& p) {
  const double x = p[0];
  const double y = p[1] / taperY(x);
  const double z = (p[2] - bendZ(x)) / taperZ(x);
  return organPoint({x / kAx, y / kAy, z / kAz});
}

}  // namespace

TriMesh makeSlab(double sx, double sy, double sz, int nx, int ny, int nz) {
  TriMesh m;
  const std::array<int, 3> n{nx, ny, nz};
  const std::array<double, 3> size{sx, sy, sz};
  std::vector<std::int64_t> id(static_cast<std::size_t>((nx + 1) * (ny + 1) * (nz + 1)), -1);
  auto vertex = [&](std::array<int, 3> c) {
    const auto key = static_cast<std::size_t>((c[2] * (ny + 1) + c[1]) * (nx + 1) + c[0]);
    if (id[key] < 0) {
      id[key] = static_cast<std::int64_t>(m.points.size());
      Vec3 p;
      for (int a = 0; a < 3; ++a)
        p[static_cast<std::size_t>(a)] =
            size[static_cast<std::size_t>(a)] *
            (static_cast<double>(c[static_cast<std::size_t>(a)]) / n[static_cast<std::size_t>(a)] - 0.5);
      m.points.push_back(p);
    }
    return static_cast<std::uint32_t>(id[key]);
  };
  // Side `s` of axis `a`; b and c follow a cyclically, so e_b x e_c = e_a.
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    for (int s = 0; s < 2; ++s) {
      for (int u = 0; u < n[static_cast<std::size_t>(b)]; ++u) {
        for (int v = 0; v < n[static_cast<std::size_t>(c)]; ++v) {
          std::array<std::uint32_t, 4> q{};
          const int du[4] = {0, 1, 1, 0}, dv[4] = {0, 0, 1, 1};
          for (int k = 0; k < 4; ++k) {
            std::array<int, 3> cell{};
            cell[static_cast<std::size_t>(a)] = s * n[static_cast<std::size_t>(a)];
            cell[static_cast<std::size_t>(b)] = u + du[k];
            cell[static_cast<std::size_t>(c)] = v + dv[k];
            q[static_cast<std::size_t>(k)] = vertex(cell);
          }
          const bool flip = (u + v) % 2 == 1;
          if (s == 1)
            addQuad(m, q[0], q[1], q[2], q[3], flip);
          else
            addQuad(m, q[0], q[3], q[2], q[1], flip);
        }
      }
    }
  }
  return m;
}

TriMesh makeDisc(double radius, double thickness, int rings, int layers) {
  return makeCapped(radius, thickness, rings, layers);
}

TriMesh makeCylinder(double radius, double height, int rings, int layers) {
  return makeCapped(radius, height, rings, layers);
}

TriMesh makeOrgan(int frequency, int relaxIterations) {
  const double phi = 0.5 * (1.0 + std::sqrt(5.0));
  const std::vector<Vec3> ico = {{-1, phi, 0},  {1, phi, 0},  {-1, -phi, 0}, {1, -phi, 0}, {0, -1, phi},  {0, 1, phi},
                                 {0, -1, -phi}, {0, 1, -phi}, {phi, 0, -1},  {phi, 0, 1},  {-phi, 0, -1}, {-phi, 0, 1}};
  std::vector<Tri> icoFaces = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                               {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                               {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (auto& f : icoFaces) {
    const Vec3 nrm = cross(ico[f[1]] - ico[f[0]], ico[f[2]] - ico[f[0]]);
    if (dot(nrm, ico[f[0]] + ico[f[1]] + ico[f[2]]) < 0) std::swap(f[1], f[2]);
  }
  TriMesh m;
  // A lattice point is identified by its integer weights on the base corners, so
  // points on shared edges are found again exactly.
  std::map<std::vector<std::pair<std::uint32_t, int>>, std::uint32_t> ids;
  const int n = frequency;
  for (const auto& f : icoFaces) {
    auto point = [&](int i, int j) {
      std::vector<std::pair<std::uint32_t, int>> key;
      const int w[3] = {n - i - j, i, j};
      for (int k = 0; k < 3; ++k)
        if (w[k] > 0) key.emplace_back(f[static_cast<std::size_t>(k)], w[k]);
      std::sort(key.begin(), key.end());
      auto it = ids.find(key);
      if (it != ids.end()) return it->second;
      Vec3 p{0, 0, 0};
      for (const auto& [c, wt] : key) p = p + (static_cast<double>(wt) / n) * ico[c];
      const std::uint32_t id = idx(m.points.size());
      m.points.push_back((1.0 / norm(p)) * p);
      ids.emplace(std::move(key), id);
      return id;
    };
    for (int i = 0; i < n; ++i) {
      for (int j = 0; i + j < n; ++j) {
        m.triangles.push_back({point(i, j), point(i + 1, j), point(i, j + 1)});
        if (i + j + 2 <= n) m.triangles.push_back({point(i + 1, j), point(i + 1, j + 1), point(i, j + 1)});
      }
    }
  }
  for (auto& p : m.points) p = organPoint(p);

  // Relax: move each vertex halfway to its neighbours' mean and back onto the surface.
  std::vector<std::vector<std::uint32_t>> nbr(m.points.size());
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) {
      const auto a = t[static_cast<std::size_t>(k)], b = t[static_cast<std::size_t>((k + 1) % 3)];
      nbr[a].push_back(b);
      nbr[b].push_back(a);
    }
  for (auto& l : nbr) {
    std::sort(l.begin(), l.end());
    l.erase(std::unique(l.begin(), l.end()), l.end());
  }
  for (int it = 0; it < relaxIterations; ++it) {
    std::vector<Vec3> next(m.points.size());
    for (std::size_t v = 0; v < m.points.size(); ++v) {
      Vec3 mean{0, 0, 0};
      for (auto w : nbr[v]) mean = mean + m.points[w];
      mean = (1.0 / static_cast<double>(nbr[v].size())) * mean;
      next[v] = projectOrgan(m.points[v] + 0.5 * (mean - m.points[v]));
    }
    m.points = std::move(next);
  }
  // Centre the bounding box at the origin.
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const auto& p : m.points)
    for (std::size_t a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  const Vec3 c = 0.5 * (lo + hi);
  for (auto& p : m.points) p = p - c;
  return m;
}

MeshCheck check(const TriMesh& m) {
  MeshCheck r;
  auto fail = [&](const std::string& s) {
    if (r.problem.empty()) r.problem = s;
  };
  const std::size_t nv = m.points.size();
  auto key = [](std::uint32_t a, std::uint32_t b) { return (static_cast<std::uint64_t>(a) << 32) | b; };
  std::unordered_set<std::uint64_t> directed;
  bool manifold = true;
  for (std::size_t f = 0; f < m.triangles.size(); ++f) {
    const auto& t = m.triangles[f];
    if (t[0] >= nv || t[1] >= nv || t[2] >= nv) {
      fail("triangle " + std::to_string(f) + " has an index out of range");
      return r;
    }
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      manifold = false;
      fail("triangle " + std::to_string(f) + " repeats a vertex");
    }
    for (int k = 0; k < 3; ++k)
      if (!directed.insert(key(t[static_cast<std::size_t>(k)], t[static_cast<std::size_t>((k + 1) % 3)])).second) {
        manifold = false;
        fail("directed edge used twice at triangle " + std::to_string(f));
      }
  }
  bool closed = true;
  for (auto e : directed)
    if (!directed.count((e << 32) | (e >> 32))) {
      closed = false;
      fail("boundary edge found");
      break;
    }
  // Every vertex's fan must be one cycle (no two cones touching at a vertex).
  if (manifold && closed) {
    std::vector<std::unordered_map<std::uint32_t, std::uint32_t>> fan(nv);
    for (const auto& t : m.triangles)
      for (int k = 0; k < 3; ++k)
        fan[t[static_cast<std::size_t>(k)]][t[static_cast<std::size_t>((k + 1) % 3)]] =
            t[static_cast<std::size_t>((k + 2) % 3)];
    for (std::size_t v = 0; v < nv; ++v) {
      if (fan[v].empty()) {
        manifold = false;
        fail("unreferenced vertex " + std::to_string(v));
        continue;
      }
      const auto start = fan[v].begin()->first;
      auto cur = start;
      std::size_t steps = 0;
      do {
        cur = fan[v].at(cur);
        ++steps;
      } while (cur != start && steps <= fan[v].size());
      if (steps != fan[v].size()) {
        manifold = false;
        fail("non-manifold vertex " + std::to_string(v));
      }
    }
  }
  r.manifold = manifold;
  r.closed = closed && !m.triangles.empty();

  std::vector<std::uint32_t> parent(nv);
  std::iota(parent.begin(), parent.end(), 0u);
  std::function<std::uint32_t(std::uint32_t)> find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& t : m.triangles) {
    parent[find(t[1])] = find(t[0]);
    parent[find(t[2])] = find(t[0]);
  }
  std::unordered_set<std::uint32_t> roots;
  for (const auto& t : m.triangles) roots.insert(find(t[0]));
  r.components = static_cast<int>(roots.size());

  r.minAngleDeg = 180.0;
  r.min = {1e300, 1e300, 1e300};
  r.max = {-1e300, -1e300, -1e300};
  for (const auto& p : m.points)
    for (std::size_t a = 0; a < 3; ++a) {
      r.min[a] = std::min(r.min[a], p[a]);
      r.max[a] = std::max(r.max[a], p[a]);
    }
  for (const auto& t : m.triangles) {
    const Vec3 &a = m.points[t[0]], &b = m.points[t[1]], &c = m.points[t[2]];
    r.volume += dot(a, cross(b, c)) / 6.0;
    const Vec3 e[3] = {b - a, c - b, a - c};
    const double area2 = norm(cross(e[0], e[1]));
    double longest = 0.0;
    for (int k = 0; k < 3; ++k) {
      longest = std::max(longest, norm(e[k]));
      const Vec3 u = e[k], w = -1.0 * e[(k + 2) % 3];  // the two edges leaving one corner
      const double cosA = dot(u, w) / (norm(u) * norm(w));
      r.minAngleDeg = std::min(r.minAngleDeg, std::acos(std::clamp(cosA, -1.0, 1.0)) * 180.0 / kPi);
    }
    r.maxAspect =
        std::max(r.maxAspect, area2 > 0 ? longest * longest / area2 : std::numeric_limits<double>::infinity());
  }
  r.outward = r.volume > 0.0;
  if (!r.outward) fail("enclosed volume is not positive (faces point inwards)");
  return r;
}

namespace {

std::string num(double x) {
  if (std::abs(x) < 5e-6) return "0";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.5f", x);
  std::string s = buf;
  while (!s.empty() && s.back() == '0') s.pop_back();
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s;
}

std::string pointText(const Vec3& p) { return num(p[0]) + " " + num(p[1]) + " " + num(p[2]); }

}  // namespace

std::vector<ModelSpec> defaultModels() {
  return {
      {"tissue_slab", "tissue slab 80 x 60 x 5 mm, top face at z = +2.5",
       [] { return makeSlab(80.0, 60.0, 5.0, 54, 40, 4); }, true},
      {"disc", "thin disc, radius 25 mm, 2 mm thick, axis z", [] { return makeDisc(25.0, 2.0, 17, 1); }, false},
      {"cylinder", "cylinder, radius 10 mm, 40 mm long, axis z", [] { return makeCylinder(10.0, 40.0, 7, 27); }, false},
      {"organ", "organ-like closed blob about 100 x 70 x 40 mm", [] { return makeOrgan(22, 10); }, false},
  };
}

void writeObj(const TriMesh& m, std::ostream& out, const std::string& comment) {
  out << "# " << comment << "\n# " << m.points.size() << " vertices, " << m.triangles.size() << " triangles\n";
  for (const auto& p : m.points) out << "v " << pointText(p) << '\n';
  for (const auto& t : m.triangles) out << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
}

void writeVrml1(const TriMesh& m, std::ostream& out, const std::string& comment) {
  out << "#VRML V1.0 ascii\n# " << comment << "\n# " << m.points.size() << " vertices, " << m.triangles.size()
      << " triangles\nSeparator {\n  Material { diffuseColor 0.85 0.45 0.42 }\n"
      << "  ShapeHints { vertexOrdering COUNTERCLOCKWISE shapeType SOLID }\n  Coordinate3 {\n    point [\n";
  for (std::size_t i = 0; i < m.points.size(); ++i)
    out << "      " << pointText(m.points[i]) << (i + 1 < m.points.size() ? ",\n" : "\n");
  out << "    ]\n  }\n  IndexedFaceSet {\n    coordIndex [\n";
  for (std::size_t i = 0; i < m.triangles.size(); ++i) {
    const auto& t = m.triangles[i];
    out << "      " << t[0] << ", " << t[1] << ", " << t[2] << ", -1" << (i + 1 < m.triangles.size() ? ",\n" : "\n");
  }
  out << "    ]\n  }\n}\n";
}

void writeVrml2(const TriMesh& m, std::ostream& out, const std::string& comment) {
  out << "#VRML V2.0 utf8\n# " << comment << "\n# " << m.points.size() << " vertices, " << m.triangles.size()
      << " triangles\nShape {\n  appearance Appearance {\n    material Material { diffuseColor 0.85 0.45 0.42 }\n"
      << "  }\n  geometry IndexedFaceSet {\n    ccw TRUE\n    solid TRUE\n    coord Coordinate {\n      point [\n";
  for (std::size_t i = 0; i < m.points.size(); ++i)
    out << "        " << pointText(m.points[i]) << (i + 1 < m.points.size() ? ",\n" : "\n");
  out << "      ]\n    }\n    coordIndex [\n";
  for (std::size_t i = 0; i < m.triangles.size(); ++i) {
    const auto& t = m.triangles[i];
    out << "      " << t[0] << ", " << t[1] << ", " << t[2] << ", -1" << (i + 1 < m.triangles.size() ? ",\n" : "\n");
  }
  out << "    ]\n  }\n}\n";
}

}  // namespace ld::models
