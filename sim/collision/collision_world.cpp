#include "sim/collision/collision_world.h"

#include <algorithm>
#include <string>

namespace ld::collision {

using Eigen::Vector3d;

ObjectId CollisionWorld::add(const mesh::SurfaceMesh& m) {
  Entry e;
  e.id = next_++;
  e.mesh = &m;
  e.bvh = TriangleBvh(m, tol_);
  entries_.push_back(std::move(e));
  return entries_.back().id;
}

const CollisionWorld::Entry& CollisionWorld::entry(ObjectId id) const {
  auto it = std::lower_bound(entries_.begin(), entries_.end(), id, [](const Entry& e, ObjectId x) { return e.id < x; });
  if (it == entries_.end() || it->id != id)
    throw CollisionError("CollisionWorld: no object with id " + std::to_string(id));
  return *it;
}

CollisionWorld::Entry& CollisionWorld::entry(ObjectId id) { return const_cast<Entry&>(std::as_const(*this).entry(id)); }

void CollisionWorld::remove(ObjectId id) {
  const Entry& e = entry(id);
  entries_.erase(entries_.begin() + (&e - entries_.data()));
}

void CollisionWorld::rebind(ObjectId id, const mesh::SurfaceMesh& m) { entry(id).mesh = &m; }

bool CollisionWorld::contains(ObjectId id) const {
  auto it = std::lower_bound(entries_.begin(), entries_.end(), id, [](const Entry& e, ObjectId x) { return e.id < x; });
  return it != entries_.end() && it->id == id;
}

std::vector<ObjectId> CollisionWorld::objects() const {
  std::vector<ObjectId> ids;
  for (const Entry& e : entries_) ids.push_back(e.id);
  return ids;
}

const mesh::SurfaceMesh& CollisionWorld::mesh(ObjectId id) const { return *entry(id).mesh; }
const TriangleBvh& CollisionWorld::bvh(ObjectId id) const { return entry(id).bvh; }
TriangleBvh& CollisionWorld::bvh(ObjectId id) { return entry(id).bvh; }

void CollisionWorld::sync() {
  for (Entry& e : entries_) e.bvh.sync(*e.mesh);
}

void CollisionWorld::rebuild(ObjectId id) {
  Entry& e = entry(id);
  e.bvh.build(*e.mesh);
}

void CollisionWorld::refit() {
  for (Entry& e : entries_) {
    e.current();
    e.bvh.refit(*e.mesh);
  }
}

void CollisionWorld::refitVertices(ObjectId id, std::span<const mesh::Vertex> moved) {
  Entry& e = entry(id);
  e.current();
  e.bvh.refitVertices(*e.mesh, moved);
}

void CollisionWorld::refitVertices(ObjectId id, std::span<const std::uint32_t> moved) {
  Entry& e = entry(id);
  e.current();
  e.bvh.refitVertices(*e.mesh, moved);
}

void CollisionWorld::setMotionMargin(ObjectId id, double margin) {
  Entry& e = entry(id);
  e.current();
  e.bvh.setMotionMargin(*e.mesh, margin);
}

std::size_t CollisionWorld::refitMoved(ObjectId id, double maxMove) {
  Entry& e = entry(id);
  e.current();
  return e.bvh.refitMoved(*e.mesh, maxMove);
}

SyncResult CollisionWorld::remap(ObjectId id, const mesh::Compaction& c) {
  Entry& e = entry(id);
  return e.bvh.remap(*e.mesh, c);
}

void CollisionWorld::intersectSegment(const Vector3d& a, const Vector3d& b, std::vector<ObjectHit>& out) const {
  out.clear();
  std::vector<SurfaceHit> hits;
  for (const Entry& e : entries_) {
    e.current().intersectSegment(*e.mesh, a, b, hits);
    for (const SurfaceHit& h : hits) out.push_back({e.id, h});
  }
  std::stable_sort(out.begin(), out.end(), [](const ObjectHit& x, const ObjectHit& y) { return x.hit.t < y.hit.t; });
}

std::optional<ObjectHit> CollisionWorld::firstHit(const Vector3d& a, const Vector3d& b) const {
  std::optional<ObjectHit> best;
  SurfaceHit h;
  for (const Entry& e : entries_)
    if (e.current().firstHit(*e.mesh, a, b, h) && (!best || h.t < best->hit.t)) best = ObjectHit{e.id, h};
  return best;
}

bool CollisionWorld::anyHit(const Vector3d& a, const Vector3d& b) const {
  for (const Entry& e : entries_)
    if (e.current().anyHit(*e.mesh, a, b)) return true;
  return false;
}

std::vector<SegmentContacts> CollisionWorld::query(instruments::Tool tool, const instruments::Pose& pose,
                                                   const instruments::Settings& settings) const {
  const auto segs = instruments::segments(tool, pose, settings);
  std::vector<SegmentContacts> out(segs.size());
  for (std::size_t i = 0; i < segs.size(); ++i) {
    out[i].index = i;
    out[i].segment = segs[i];
    intersectSegment(segs[i].a, segs[i].b, out[i].hits);
  }
  return out;
}

std::vector<SegmentSweep> CollisionWorld::sweep(instruments::Tool tool, const instruments::Pose& before,
                                                const instruments::Pose& after, const instruments::Settings& settings,
                                                const SweepSettings& sweepSettings) const {
  const auto s0 = instruments::segments(tool, before, settings);
  const auto s1 = instruments::segments(tool, after, settings);
  SweepSettings ss = sweepSettings;
  ss.tol = tol_;  // one tolerance for the whole world
  std::vector<SegmentSweep> out(std::min(s0.size(), s1.size()));
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i].index = i;
    out[i].before = s0[i];
    out[i].after = s1[i];
    for (const Entry& e : entries_) {
      SweptContacts c = sweepSegment(*e.mesh, &e.current(), s0[i].a, s0[i].b, s1[i].a, s1[i].b, ss);
      if (!c.faces.empty()) out[i].objects.push_back({e.id, std::move(c)});
    }
  }
  return out;
}

}  // namespace ld::collision
