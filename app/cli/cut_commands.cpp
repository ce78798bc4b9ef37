// lapdissect-cli cut --mesh FILE --trajectory CSV [--physics off|on] [--out FILE]
// (contract in DESIGN.md): replays a trajectory against a tissue model with the
// progressive cutter and reports what the cut did to the mesh.
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "app/cli/cli.h"
#include "devices/trajectory.h"
#include "sim/cutting/cutter.h"
#include "sim/cutting/mesh_checks.h"
#include "sim/io/mesh_io.h"
#include "sim/physics/mass_spring.h"
#include "sim/physics/tissue_properties.h"

namespace ld::cli {
namespace {

// All pieces as one mesh (disjoint union) for writing.
mesh::SurfaceMesh unionOf(const std::vector<cutting::TissueObject>& objects) {
  mesh::SurfaceMesh out;
  for (const auto& o : objects) {
    std::vector<mesh::Vertex> map(o.mesh.verticesSize());
    for (mesh::Vertex v : o.mesh.vertices()) map[v.idx()] = out.addVertex(o.mesh.position(v));
    for (mesh::Face f : o.mesh.faces()) {
      const auto& v = o.mesh.vertices(f);
      out.addFace(map[v[0].idx()], map[v[1].idx()], map[v[2].idx()]);
    }
  }
  return out;
}

int cut(const Args& args) {
  const std::string meshFile = args.get("mesh");
  const std::string csv = args.get("trajectory");
  const std::string physicsMode = args.get("physics", "off");
  if (physicsMode != "on" && physicsMode != "off")
    throw CliError(kBadInput, "option --physics: expected 'on' or 'off', found '" + physicsMode + "'");
  const bool physicsOn = physicsMode == "on";
  // Extension: --active-region on integrates only the awake vertices (physics' active
  // region) and refits the collision tree only around them.
  const std::string regionMode = args.get("active-region", "off");
  if (regionMode != "on" && regionMode != "off")
    throw CliError(kBadInput, "option --active-region: expected 'on' or 'off', found '" + regionMode + "'");

  mesh::SurfaceMesh m = io::readMesh(meshFile);
  const devices::Trajectory tr = devices::readTrajectoryCsv(csv);

  cutting::CutParams params;
  physics::TissueParams tissue;
  // Physics runs in steps of at most kPhysicsDt (the workstation's 1 kHz loop); the
  // mass floor keeps that step stable on the short, stiff edges cutting makes.
  constexpr double kPhysicsDt = 1e-3;
  tissue.massFloorDt = kPhysicsDt;
  params.tissue = tissue;
  // Physics moves every vertex a little each step: fat collision boxes (a vertex's
  // leaves are refitted only once it moved farther than this) instead of a full
  // refit per step. Extension: --collision-margin MM (0 = full refits).
  params.collisionMargin = physicsOn ? args.getDouble("collision-margin", 0.25) : 0.0;
  if (physicsOn) physics::attachTissueProperties(m, tissue);
  const std::size_t facesBefore = m.nFaces();
  cutting::CutEngine engine(params);
  engine.addObject(std::move(m));
  if (physicsOn) engine.settleAdded();  // marks the model's vertices settled

  // Physics (--physics on): one Dynamics per object, stepping the engine's own mesh in
  // place (the cutter owns the topology, physics moves the vertices; object() tells the
  // engine to refit its collision tree before the next sample).
  physics::Params pp;
  pp.tissue = tissue;
  pp.active.enabled = regionMode == "on";
  // Nothing here sets an external force (no grasper, the blade only cuts): no scan of
  // every vertex's force each step (50k at 100k triangles; the cuts' edits wake theirs).
  pp.active.scanExternalForces = false;
  pp.groupMoves = true;                                      // for the collision tree (verticesTravelled below)
  std::vector<std::unique_ptr<physics::Dynamics>> dynamics;  // stable addresses
  std::vector<int> dynamicsOf;
  double physicsSeconds = 0.0;
  long physicsSteps = 0;
  double regionSeconds = 0.0, regionVertices = 0.0;  // the steps that integrated a region only
  long regionSteps = 0;
  auto stepPhysics = [&](double dt) {
    if (!physicsOn || !(dt > 0.0)) return;
    const std::size_t n = engine.objects().size();
    for (std::size_t i = 0; i < n; ++i) {
      const int id = engine.objects()[i].id;
      std::size_t k = 0;
      while (k < dynamicsOf.size() && dynamicsOf[k] != id) ++k;
      if (k == dynamicsOf.size()) {
        dynamics.push_back(std::make_unique<physics::Dynamics>());
        dynamicsOf.push_back(id);
      }
      const int substeps = std::max(1, static_cast<int>(std::ceil(dt / kPhysicsDt - 1e-9)));
      mesh::SurfaceMesh& mesh = engine.meshToMove(id);
      // Each group's travel summed by the physics, against this object's tree.
      pp.travelLimit = engine.travelLimit(id);
      pp.travelPad = engine.travelPad(id);
      for (int j = 0; j < substeps; ++j) {
        const auto t0 = std::chrono::steady_clock::now();
        const physics::StepInfo info = physics::step(pp, *dynamics[k], mesh, dt / substeps);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        physicsSeconds += seconds;
        ++physicsSteps;
        if (pp.active.enabled && info.activeVertices < mesh.nVertices()) {  // a region, not all of it
          regionSeconds += seconds;
          ++regionSteps;
          regionVertices += static_cast<double>(info.activeVertices);
        }
        // The collision tree refits around what moved (all of it without an active region).
        if (const auto moved = physics::movedVertices(*dynamics[k]))
          engine.verticesMoved(id, *moved);
        else
          engine.verticesTravelled(id, dynamics[k]->maxMove, dynamics[k]->groupTravel(), dynamics[k]->groupsPastLimit(),
                                   physics::Dynamics::kMoveGroup);
        dynamics[k]->clearGroupsPastLimit();
      }
    }
  };

  double lastT = tr.samples.empty() ? 0.0 : tr.samples.front().t;
  for (const auto& s : tr.samples) {
    stepPhysics(s.t - lastT);
    lastT = s.t;
    const cutting::StepResult r = engine.step(s.hand, s.tool, s.pose);
    if (physicsOn) engine.settleAdded(r.preview);  // what the cut added, except the tips
  }
  engine.finish();
  if (physicsOn) engine.settleAdded();

  const auto& st = engine.stats();
  bool manifold = true, closed = true, nan = false;
  double minArea = std::numeric_limits<double>::infinity(), minAngle = 180.0;
  long components = 0, faces = 0;
  for (const auto& o : engine.objects()) {
    const auto q = cutting::measureQuality(o.mesh);
    manifold = manifold && q.manifoldVertices && o.mesh.validate().ok();
    closed = closed && q.closed;
    nan = nan || !q.finite;
    if (o.mesh.nFaces() > 0) {
      minArea = std::min(minArea, q.minArea);
      minAngle = std::min(minAngle, q.minAngleDeg);
    }
    components += q.components;
    faces += static_cast<long>(o.mesh.nFaces());
  }
  if (!std::isfinite(minArea)) minArea = 0.0;

  if (args.has("out")) io::writeMesh(unionOf(engine.objects()), args.get("out"));

  nlohmann::json j;
  j["triangles_cut"] = st.trianglesCut;
  j["triangles_added"] = faces - static_cast<long>(facesBefore);
  j["vertices_added"] = st.verticesAdded;
  j["components"] = components;
  j["manifold"] = manifold;
  j["closed"] = closed;
  j["min_triangle_area"] = minArea;
  j["remesh_us_per_cut_triangle"] = st.remeshMicrosPerCutTriangle();
  j["nan"] = nan;
  j["min_triangle_angle_deg"] = minAngle;
  j["objects"] = engine.objects().size();
  j["separations"] = st.separations;
  j["samples"] = tr.samples.size();
  j["triangles_added_per_cut_triangle"] =
      st.trianglesCut > 0 ? static_cast<double>(faces - static_cast<long>(facesBefore)) / st.trianglesCut : 0.0;
  j["walk_failures"] = st.walkFailures;
  // How the failing walks ended (only the ends that occurred; sim/cutting/cutter.h).
  j["walk_failures_by"] = nlohmann::json::object();
  for (std::size_t k = 0; k < cutting::kWalkEnds; ++k)
    if (st.walkFailuresBy[k] > 0)
      j["walk_failures_by"][cutting::walkEndName(static_cast<cutting::WalkEnd>(k))] = st.walkFailuresBy[k];
  j["lip_stops"] = st.lipStops;
  j["starts_merged"] = st.startsMerged;  // tracks that ran into an earlier cut at their start (not failures)
  j["starts_closed"] = st.startsClosed;  // grooves come round to their start and closed into a ring
  j["starts_opened"] = st.startsOpened;  // of those, the ones whose start then opened (no pinch in the ring)
  j["fill_failures"] = st.fillFailures;
  j["physics"] = physicsMode;
  j["active_region"] = regionMode;
  j["collision_us_per_query"] = st.collisionQueries > 0 ? st.collisionSeconds * 1e6 / st.collisionQueries : 0.0;
  j["collision_queries"] = st.collisionQueries;
  j["collision_full_refits"] = st.fullRefits;
  j["collision_region_refits"] = st.regionRefits;
  j["collision_margin"] = params.collisionMargin;
  j["collision_margin_refits"] = st.marginRefits;
  j["collision_margin_passes"] = st.marginPasses;
  j["collision_vertices_reanchored"] = st.verticesReanchored;
  j["collision_vertices_refitted"] = st.verticesRefitted;
  j["separation_ms"] = st.separationSeconds * 1e3;
  j["fast_samples"] = st.fastSamples;
  j["slow_samples"] = st.slowSamples;
  // How the groove's bottom was kept (reused or slid bottom vertices make no triangles)
  // and what the safety nets did.
  j["bottom_slides"] = st.bottomSlides;
  j["flips"] = st.flips;
  j["sliver_snaps"] = st.sliverSnaps;
  j["holds"] = st.holds;
  if (physicsOn) {
    j["physics_us_per_step"] = physicsSteps > 0 ? physicsSeconds * 1e6 / physicsSteps : 0.0;
    j["physics_steps"] = physicsSteps;
    if (pp.active.enabled) {  // the steps after the balance: what a touched region costs
      j["physics_region_steps"] = regionSteps;
      j["physics_us_per_region_step"] = regionSteps > 0 ? regionSeconds * 1e6 / regionSteps : 0.0;
      j["physics_region_vertices_mean"] = regionSteps > 0 ? regionVertices / regionSteps : 0.0;
    }
    std::uint64_t warnings = 0, fallbacks = 0;
    for (const auto& d : dynamics) {
      warnings += d->stability.warnings;
      fallbacks += d->stability.implicitFallbacks;
    }
    j["physics_rejected_steps"] = warnings;  // the stability monitor's retries (recovered)
    j["physics_implicit_fallbacks"] = fallbacks;
  }
  printJson(j);
  return kOk;
}

}  // namespace

int runCut(const Args& args) {
  try {
    return cut(args);
  } catch (const io::ParseError& e) {
    throw CliError(kBadInput, e.what());
  } catch (const io::IoError& e) {
    throw CliError(kBadInput, e.what());
  } catch (const devices::ParseError& e) {
    throw CliError(kBadInput, e.what());
  }
}

}  // namespace ld::cli
