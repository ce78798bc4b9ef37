// Active-region mode (the thesis's local deformation, with sleeping): only awake
// vertices are integrated; a vertex wakes when an external force acts on it (contact)
// or a moving neighbour pulls it, and falls asleep after a run of quiet steps.
#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/physics/mass_spring.h"

namespace ld::physics {

using Vec3 = Eigen::Vector3d;

namespace {

enum : std::uint8_t { kAsleep = 0, kAwake = 1, kLeaving = 2 };  // kLeaving: asleep, still listed

void buildCsr(detail::ActiveSet& a, const detail::Cache& c) {
  const std::size_t n = c.nVertexSlots;
  a.csrStart.assign(n + 1, 0);
  for (const auto& sp : c.springs) {
    ++a.csrStart[sp.i + 1];
    ++a.csrStart[sp.j + 1];
  }
  for (std::size_t i = 0; i < n; ++i) a.csrStart[i + 1] += a.csrStart[i];
  a.csrSpring.assign(a.csrStart[n], 0);
  std::vector<std::uint32_t> fill(a.csrStart.begin(), a.csrStart.end() - 1);
  for (std::uint32_t k = 0; k < c.springs.size(); ++k) {
    a.csrSpring[fill[c.springs[k].i]++] = k;
    a.csrSpring[fill[c.springs[k].j]++] = k;
  }
  a.added.clear();
  a.hasAdded.assign(n, 0);
  a.springsSeen = c.springs.size();
}

// Calls fn(j, spring) for every spring at vertex i (dead ones have k = rest = 0).
template <class F>
void forEachSpring(const detail::ActiveSet& a, const detail::Cache& c, std::uint32_t i, F&& fn) {
  if (i + 1 < a.csrStart.size())
    for (std::uint32_t k = a.csrStart[i]; k < a.csrStart[i + 1]; ++k) {
      const auto& sp = c.springs[a.csrSpring[k]];
      fn(sp.i ^ sp.j ^ i, sp);  // the other end, without a branch the CPU cannot predict
    }
  if (i >= a.hasAdded.size() || !a.hasAdded[i]) return;
  auto it = std::lower_bound(a.added.begin(), a.added.end(), std::pair<std::uint32_t, std::uint32_t>(i, 0));
  for (; it != a.added.end() && it->first == i; ++it) {
    const auto& sp = c.springs[it->second];
    fn(sp.i ^ sp.j ^ i, sp);  // the other end, without a branch the CPU cannot predict
  }
}

void wakeVertex(detail::ActiveSet& a, const detail::Cache& c, std::uint32_t j, bool contact);

// Brings the set up to the cache and the mesh. Edits in place (a cut) keep every
// vertex's state and wake only the vertices the edits touched (the journal's
// vertices, the ends of its edges — every new spring is one — the corners of its faces):
// the cut's neighbourhood, not the whole tissue. Cost O(edits) plus, after a
// cache rebuild, O(springs) for the adjacency. A new layout (or the first step)
// starts with every vertex awake; the quiet ones fall asleep within sleepAfter steps.
void ensureActiveSet(Dynamics& s, const mesh::SurfaceMesh& m) {
  auto& a = s.active;
  const auto& c = s.cache;
  const std::size_t n = c.nVertexSlots;
  const bool sameLayout = a.layoutVersion == m.layoutVersion() && a.journalV <= m.editedVertices().size() &&
                          a.journalE <= m.editedEdges().size() && a.journalF <= m.editedFaces().size() &&
                          a.awake.size() <= n && !a.awake.empty();
  if (sameLayout && a.rebuilds == c.rebuilds && a.springsSeen == c.springs.size() && a.awake.size() == n &&
      a.journalV == m.editedVertices().size() && a.journalE == m.editedEdges().size() &&
      a.journalF == m.editedFaces().size())
    return;
  if (!sameLayout) {
    buildCsr(a, c);
    a.awake.assign(n, kAsleep);
    a.quiet.assign(n, 0);
    a.list.clear();
    for (std::uint32_t i = 0; i < n; ++i)
      if (c.invMass[i] != 0.0) {
        a.awake[i] = kAwake;
        a.list.push_back(i);
      }
    ++a.restarts;
  } else {
    const std::size_t seen = a.springsSeen;
    if (a.rebuilds != c.rebuilds) {
      buildCsr(a, c);
    } else {
      a.hasAdded.resize(n, 0);
      for (std::size_t k = seen; k < c.springs.size(); ++k) {
        a.added.emplace_back(c.springs[k].i, static_cast<std::uint32_t>(k));
        a.added.emplace_back(c.springs[k].j, static_cast<std::uint32_t>(k));
        a.hasAdded[c.springs[k].i] = a.hasAdded[c.springs[k].j] = 1;
      }
      std::sort(a.added.begin(), a.added.end());
      a.springsSeen = c.springs.size();
    }
    a.awake.resize(n, kAsleep);
    a.quiet.resize(n, 0);
    // Deleted (massless) vertices leave the list.
    std::size_t kept = 0;
    for (const std::uint32_t i : a.list) {
      if (c.invMass[i] != 0.0)
        a.list[kept++] = i;
      else
        a.awake[i] = kAsleep;
    }
    a.list.resize(kept);
    for (const mesh::Vertex v : m.editedVertices().subspan(a.journalV)) wakeVertex(a, c, v.idx(), true);
    for (const mesh::Edge e : m.editedEdges().subspan(a.journalE))
      if (!m.isDeleted(e))
        for (int end = 0; end < 2; ++end) wakeVertex(a, c, m.vertex(e, end).idx(), true);
    for (const mesh::Face f : m.editedFaces().subspan(a.journalF))
      if (!m.isDeleted(f))
        for (const mesh::Vertex v : m.vertices(f)) wakeVertex(a, c, v.idx(), true);
  }
  a.rebuilds = c.rebuilds;
  a.layoutVersion = m.layoutVersion();
  a.journalV = m.editedVertices().size();
  a.journalE = m.editedEdges().size();
  a.journalF = m.editedFaces().size();
}

// Newly woken vertices join the list's end; one that fell asleep earlier in this step
// is still listed and only changes state. A contact restarts the quiet count of an
// awake vertex too; a moving neighbour only wakes sleepers.
void wakeVertex(detail::ActiveSet& a, const detail::Cache& c, std::uint32_t j, bool contact) {
  // (The awake byte first: inside the region that is the answer, without the mass's line.)
  if (j >= a.awake.size() || (!contact && a.awake[j] == kAwake) || c.invMass[j] == 0.0) return;
  a.quiet[j] = 0;
  if (a.awake[j] == kAsleep) a.list.push_back(j);
  a.awake[j] = kAwake;
}

}  // namespace

std::optional<std::span<const std::uint32_t>> movedVertices(const Dynamics& d) {
  if (d.active.movedStep != d.steps) return std::nullopt;
  return std::span<const std::uint32_t>(d.active.moved);
}

void wake(Dynamics& d, std::span<const mesh::Vertex> vertices) {
  for (const mesh::Vertex v : vertices)
    if (v.isValid()) d.active.pending.push_back(static_cast<std::uint32_t>(v.idx()));
}

// Cost: O(awake vertices and their springs), plus O(vertices) for the force scan when
// scanExternalForces is on and on the first step after a topology change.
StepInfo activeStep(const Params& params, Dynamics& state, mesh::SurfaceMesh& mesh, double dt) {
  ensureActiveSet(state, mesh);
  auto& a = state.active;
  const auto& c = state.cache;
  auto& x = mesh.positions();
  auto& v = mesh.getVertexProperty<Vec3>(kVelocityProp).vector();
  const auto& home = mesh.getVertexProperty<Vec3>(kHomeProp).vector();
  const auto& ext = mesh.getVertexProperty<Vec3>(kForceProp).vector();
  const auto& tp = params.tissue;
  const auto& ao = params.active;
  const std::size_t n = c.nVertexSlots;

  // Contact wakes.
  if (ao.scanExternalForces)
    for (std::uint32_t i = 0; i < n; ++i)
      if (ext[i].squaredNorm() > 0.0) wakeVertex(a, c, i, true);
  for (const std::uint32_t i : a.pending) wakeVertex(a, c, i, true);
  a.pending.clear();

  // Substeps that keep the awake region stable: ω² of a vertex is at most
  // (homeK + 2 Σk)/m (Gershgorin), and a symplectic step needs ω·h < 2. A cut's short
  // edges are stiff and light; the full step finds this out by rejection, the region
  // step knows it in advance from what is awake.
  const std::size_t m = a.list.size();
  double w2 = 0.0;
  for (const std::uint32_t i : a.list) w2 = std::max(w2, (tp.homeK + 2.0 * c.vertexStiffness[i]) * c.invMass[i]);
  const double need = std::ceil(dt * std::sqrt(w2) / 1.9);
  // Only substeps commit the region before a later substep's check, so only they need
  // the start saved for a rollback.
  bool saved = false;
  const auto fallBack = [&] {
    // The monitored full step (substeps, then the implicit method) takes over.
    for (std::size_t q = 0; saved && q < m; ++q) {
      x[a.list[q]] = a.x0[q];
      v[a.list[q]] = a.v0[q];
    }
    Params full = params;
    full.active.enabled = false;
    a.layoutVersion = ~std::uint64_t{0};
    return step(full, state, mesh, dt);
  };
  if (!(need <= params.stability.maxSubsteps)) return fallBack();
  const int substeps = std::max(1, static_cast<int>(need));
  if (substeps > 1) {
    a.x0.resize(m);
    a.v0.resize(m);
    for (std::size_t q = 0; q < m; ++q) {
      a.x0[q] = x[a.list[q]];
      a.v0[q] = v[a.list[q]];
    }
    saved = true;
  }
  const double h = dt / substeps;

  // Forces for the awake vertices at the old positions (sleepers are fixed).
  auto& xn = state.cache.xt;
  auto& vn = state.cache.vt;
  xn.resize(m);
  vn.resize(m);
  a.loud.assign(m, 0);
  const double damp = 1.0 - h * tp.damping;
  const double ft2 = ao.forceThreshold * ao.forceThreshold, vt2 = ao.speedThreshold * ao.speedThreshold;
  const double maxV2 = params.stability.maxSpeed * params.stability.maxSpeed;
  for (int sub = 0; sub < substeps; ++sub) {
    bool ok = true;
    for (std::size_t q = 0; q < m; ++q) {
      const std::uint32_t i = a.list[q];
      Vec3 f = ext[i] + c.mass[i] * tp.gravity - tp.homeK * (x[i] - home[i]);
      forEachSpring(a, c, i, [&](std::uint32_t j, const detail::Spring& sp) {
        const Vec3 d = x[j] - x[i];
        const double l = d.norm();
        if (l > 0.0) f += (sp.k * (l - sp.rest) / l) * d;
      });
      vn[q] = damp * v[i] + (h * c.invMass[i]) * f;
      xn[q] = x[i] + h * vn[q];
      // Finite and below the monitor's speed bound (a divergence that stays finite).
      ok = ok && xn[q].allFinite() && vn[q].squaredNorm() <= maxV2;
      a.loud[q] |= static_cast<std::uint8_t>((f.squaredNorm() > ft2) | (vn[q].squaredNorm() > vt2));  // (no branch)
    }
    if (!ok) return fallBack();
    for (std::size_t q = 0; q < m; ++q) {
      x[a.list[q]] = xn[q];
      v[a.list[q]] = vn[q];
    }
  }
  for (std::size_t q = 0; q < m; ++q) {
    const std::uint32_t i = a.list[q];
    if (a.loud[q]) {
      a.quiet[i] = 0;
      // Propagate: a loud vertex wakes its neighbours (from the next step on).
      forEachSpring(a, c, i, [&](std::uint32_t j, const detail::Spring&) { wakeVertex(a, c, j, false); });
    } else if (++a.quiet[i] >= ao.sleepAfter && ext[i].squaredNorm() == 0.0) {
      a.awake[i] = kLeaving;
      v[i].setZero();
    }
  }
  a.moved.assign(a.list.begin(), a.list.begin() + static_cast<std::ptrdiff_t>(m));
  // Drop the vertices that fell asleep (and stayed asleep) from the list.
  std::size_t kept = 0;
  for (const std::uint32_t i : a.list) {
    if (a.awake[i] == kAwake)
      a.list[kept++] = i;
    else
      a.awake[i] = kAsleep;
  }
  a.list.resize(kept);
  state.time += dt;
  ++state.steps;
  state.maxMove = std::numeric_limits<double>::infinity();  // the moved list says what moved
  a.movedStep = state.steps;
  StepInfo info;
  info.activeVertices = m;
  info.substeps = substeps;
  return info;
}

}  // namespace ld::physics
