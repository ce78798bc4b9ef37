// Active-region mode (the thesis's local deformation, with sleeping): only awake
// vertices are integrated; a vertex wakes when an external force acts on it (contact)
// or a moving neighbour pulls it, and falls asleep after a run of quiet steps.
#include <algorithm>
#include <cmath>

#include "sim/physics/mass_spring.h"

namespace ld::physics {

using Vec3 = Eigen::Vector3d;

namespace {

enum : std::uint8_t { kAsleep = 0, kAwake = 1, kLeaving = 2 };  // kLeaving: asleep, still listed

void ensureActiveSet(Dynamics& s) {
  auto& a = s.active;
  const auto& c = s.cache;
  if (a.topologyVersion == c.topologyVersion && a.awake.size() == c.nVertexSlots) return;
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
  // Start with every vertex awake; the quiet ones fall asleep within sleepAfter steps.
  a.awake.assign(n, kAsleep);
  a.quiet.assign(n, 0);
  a.list.clear();
  for (std::uint32_t i = 0; i < n; ++i)
    if (c.invMass[i] != 0.0) {
      a.awake[i] = kAwake;
      a.list.push_back(i);
    }
  a.topologyVersion = c.topologyVersion;
}

// Newly woken vertices join the list's end; one that fell asleep earlier in this step
// is still listed and only changes state. A contact restarts the quiet count of an
// awake vertex too; a moving neighbour only wakes sleepers.
void wakeVertex(detail::ActiveSet& a, const detail::Cache& c, std::uint32_t j, bool contact) {
  if (j >= a.awake.size() || c.invMass[j] == 0.0 || (!contact && a.awake[j] == kAwake)) return;
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
  ensureActiveSet(state);
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

  // Forces for the awake vertices at the old positions (sleepers are fixed).
  const std::size_t m = a.list.size();
  auto& xn = state.cache.xt;
  auto& vn = state.cache.vt;
  xn.resize(m);
  vn.resize(m);
  a.loud.assign(m, 0);
  const double damp = 1.0 - dt * tp.damping;
  const double ft2 = ao.forceThreshold * ao.forceThreshold, vt2 = ao.speedThreshold * ao.speedThreshold;
  bool finite = true;
  for (std::size_t q = 0; q < m; ++q) {
    const std::uint32_t i = a.list[q];
    Vec3 f = ext[i] + c.mass[i] * tp.gravity - tp.homeK * (x[i] - home[i]);
    for (std::uint32_t k = a.csrStart[i]; k < a.csrStart[i + 1]; ++k) {
      const auto& sp = c.springs[a.csrSpring[k]];
      const std::uint32_t j = sp.i == i ? sp.j : sp.i;
      const Vec3 d = x[j] - x[i];
      const double l = d.norm();
      if (l > 0.0) f += (sp.k * (l - sp.rest) / l) * d;
    }
    vn[q] = damp * v[i] + (dt * c.invMass[i]) * f;
    xn[q] = x[i] + dt * vn[q];
    finite = finite && xn[q].allFinite() && vn[q].allFinite();
    a.loud[q] = f.squaredNorm() > ft2 || vn[q].squaredNorm() > vt2;
  }
  if (!finite) {
    // Let the monitored full step handle it.
    Params full = params;
    full.active.enabled = false;
    a.topologyVersion = ~std::uint64_t{0};
    return step(full, state, mesh, dt);
  }
  for (std::size_t q = 0; q < m; ++q) {
    const std::uint32_t i = a.list[q];
    x[i] = xn[q];
    v[i] = vn[q];
    if (a.loud[q]) {
      a.quiet[i] = 0;
      // Propagate: a loud vertex wakes its neighbours (from the next step on).
      for (std::uint32_t k = a.csrStart[i]; k < a.csrStart[i + 1]; ++k) {
        const auto& sp = c.springs[a.csrSpring[k]];
        wakeVertex(a, c, sp.i == i ? sp.j : sp.i, false);
      }
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
  a.movedStep = state.steps;
  StepInfo info;
  info.activeVertices = m;
  return info;
}

}  // namespace ld::physics
