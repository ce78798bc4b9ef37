#pragma once
// Progressive cutting of surface-mesh tissue objects by instrument cutting edges
// (method and design notes in sim/cutting/README.md).
//
// A CutEngine owns the tissue objects of a scene. Feed it one instrument pose per
// hand per sample with step(); it finds where the cutting edges cross the surfaces,
// follows each crossing ("track") from sample to sample across the triangles,
// inserts permanent vertices where a track crosses a mesh edge, opens the surface
// behind the blade, and closes the opening at once with groove triangles (one layer
// cut: the groove bottom follows the blade's depth) or side triangles (the blade
// passes through two layers: the walls join them). The current point inside a
// triangle is temporary: it is reported as preview geometry and only becomes a
// vertex when the blade leaves the triangle or the cut ends. A closed mesh stays
// closed, manifold and consistently oriented after every call. When a cut-through
// frees a part, it becomes an object of its own (StepResult::separated).
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "sim/cutting/cut_error.h"
#include "sim/instruments/instrument.h"
#include "sim/mesh/surface_mesh.h"
#include "sim/physics/tissue_properties.h"

namespace ld::cutting {

// Face property "f:cut_kind" (int) tells the renderer what a face is.
inline constexpr const char* kFaceKindProp = "f:cut_kind";
enum FaceKind : int { kSurface = 0, kGrooveWall = 1, kSideWall = 2 };

struct CutParams {
  // No vertex is created closer than this to an existing vertex of the triangle it
  // goes into, nor closer than this to an edge (the hit snaps to it instead) [mm].
  double snapDistance = 0.05;
  // ... and no split of an edge closer to an end than this fraction of its length.
  double snapFraction = 0.08;
  // The last step of a groove puts its bottom within this of the blade's depth; mid-
  // stroke the bottom vertex may be at least this far behind it [mm] (the walls fan
  // around it: fewer triangles per cut).
  double grooveSpacing = 1.0;
  // Smallest angle a groove's wall triangles keep where the geometry allows it [degrees]:
  // the groove-bottom vertex is reused, or slid on along the groove, while its triangles
  // keep it; else a new one goes under the blade. Lower: fewer triangles, thinner walls
  // (3 is about the surface's own worst, an edge split at snapFraction next to a vertex).
  double wallMinAngleDeg = 3.0;
  // Motion of a cutting edge longer than this between two samples is split into
  // interpolated sub-samples (the swept test: fast strokes miss nothing) [mm].
  double maxSubstep = 0.5;
  int maxSubsteps = 256;
  // A crossing matches the track of the previous sample within this distance, plus
  // twice the motion of the edge [mm].
  double matchRadius = 2.0;
  // Open (non-closed) meshes are sheets: cut without groove or side walls.
  bool wallsOnOpenMeshes = false;
  // Guards against a runaway (CutStats::tracksRefused, strokeCaps; nothing is thrown):
  // at most this many new tracks of one cutting edge on one object in one sample, and a
  // stroke (one contact of a hand) adds at most max(strokeFacesMin, strokeFacesFactor x
  // the faces the object had when the stroke first cut it) faces to an object; past
  // that its cuts there end and it starts none until the blade is out of the tissue.
  int maxNewTracksPerSample = 4;
  long strokeFacesMin = 4096;
  double strokeFacesFactor = 1.0;
  // Fat collision boxes (collision::TriangleBvh::setMotionMargin) [mm]: with tissue
  // that moves every step a moved object's tree then re-anchors only the vertices that
  // moved farther than this (half of it for named vertices: an active region's list)
  // instead of a full refit, or a refit around every named vertex. 0: tight boxes, a
  // full refit per motion. Hits are the same either way.
  double collisionMargin = 0.0;
  instruments::Settings tool;
  // Physics hooks: when the mesh carries the tissue properties (physics::
  // hasTissueProperties), new vertices and edges are initialised with these.
  physics::TissueParams tissue;
};

struct TissueObject {
  int id = 0;
  int parent = -1;  // the object it was separated from, or -1
  mesh::SurfaceMesh mesh;
  bool closedAtStart = false;  // walls are made when closed (or wallsOnOpenMeshes)
};

// An instrument segment touching a surface (every tool, cutting or not).
struct Contact {
  int object = -1;
  int segment = -1;  // index into instruments::segments(tool, pose)
  instruments::SegmentRole role = instruments::SegmentRole::CuttingEdge;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double t = 0.0;         // along the segment
  bool entering = false;  // the segment runs from outside to inside the surface here
};

// Where a cutting edge meets the surface while it cuts (one per active track per sample).
struct CutPoint {
  int object = -1;
  int segment = -1;
  int track = -1;  // stable id for the stroke's crossing of one layer
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d depth = Eigen::Vector3d::Zero();  // groove bottom / blade end inside
  bool through = false;                             // part of a cut-through (paired with another layer)
};

// Temporary geometry: from the last permanent vertex of a track to the blade's
// current point (and its depth point). Draw it over the mesh: the cut follows the
// blade at once even inside a triangle.
struct PreviewSegment {
  int object = -1;
  Eigen::Vector3d from = Eigen::Vector3d::Zero();
  Eigen::Vector3d to = Eigen::Vector3d::Zero();
  Eigen::Vector3d depth = Eigen::Vector3d::Zero();
};

struct StepResult {
  std::vector<Contact> contacts;
  std::vector<CutPoint> cutPoints;
  std::vector<PreviewSegment> preview;
  std::vector<int> separated;  // ids of objects created by separation in this step
  long trianglesCut = 0;       // triangles the cut passed through in this step
  long trianglesAdded = 0;     // net change in face count
  long verticesAdded = 0;
  bool topologyChanged = false;
};

// How a track's walk along the blade's sweep plane ended (sim/cutting/README.md, Method).
// Every end but Reached leaves the walk short of the blade's point; which of them end the
// track is the caller's choice (a lip stop, a hold, or a walk failure).
enum class WalkEnd : std::uint8_t {
  Reached,        // the point lies in a face around the tip (or the goal vertex is a neighbour)
  AtLip,          // on an earlier cut's lip, the point across its gap
  PastReach,      // a groove's curve went deeper than the blade has been
  AtRim,          // no way on at a sheet's rim or slit
  NoWay,          // the plane leaves the tip's fan nowhere ahead
  Unreached,      // the first step's traced curve misses the point: nothing was edited
  TooLong,        // ran over the walk's length
  Blocked,        // the next crossing would touch the cut itself
  NotAdjacent,    // the next vertex is no neighbour of the tip
  Refused,        // the extension did not take the step (it would pinch or make a sliver)
  AtEarlierWall,  // a cut-through's layer reached another cut's wall
  Count
};
inline constexpr std::size_t kWalkEnds = static_cast<std::size_t>(WalkEnd::Count);
// Short snake_case name ("no_way"), for reports.
[[nodiscard]] const char* walkEndName(WalkEnd e);

struct CutStats {
  long trianglesCut = 0;
  long trianglesAdded = 0;
  long verticesAdded = 0;
  long tracks = 0;
  long separations = 0;
  long walkFailures = 0;           // a track could not follow the blade and was ended
  // Of those, the ones a walk ended, by how it ended (the rest: starts whose face was
  // gone). Indexed by WalkEnd.
  std::array<long, kWalkEnds> walkFailuresBy{};
  long lipStops = 0;               // tracks ended on an earlier cut's lip, the blade across its gap (restarted there)
  long waysChosen = 0;             // walks whose first step took another way: its curve reaches the blade
  long pairsPierced = 0;           // slide-ins whose way round the edge misses the other crossing: pierced instead
  long cutOutsRefused = 0;         // cut-outs whose way to the other layer's tip misses it: both end there, unedited
  long startsClosed = 0;           // grooves come round to their own start and closed into a ring there
  long startsOpened = 0;           // of those, the ones whose start vertex then opened (no pinch in the ring)
  long startsMerged = 0;           // grooves blocked at their start by an earlier cut the blade went into: ended there
  long holds = 0;                  // track samples that waited: the blade was behind the moved tip
  long fillFailures = 0;           // an opening could not be closed (should stay 0)
  long unpinched = 0;              // pinched vertices split (safety net)
  long flips = 0;                  // edges flipped to remove thin triangles
  long bottomSlides = 0;           // groove-bottom vertices moved on along the groove (instead of new ones)
  long longestFront = 0;           // most vertices a cut's front (tip to the other side) has had
  long sliverSnaps = 0;            // points moved onto a vertex because a split there would make a sliver
  long capWelds = 0;               // cut-out loop vertices welded onto a neighbour: the cap was too thin
  long lipCrossings = 0;           // crossings on the lip or wall of the stroke's own cut (a fold): no track started
  long tracksRefused = 0;          // new tracks refused: past maxNewTracksPerSample, or on a capped stroke
  long strokeCaps = 0;             // strokes whose cuts were ended for growing an object past their budget
  double remeshSeconds = 0.0;      // time in topology edits (walks, splits, walls), collision queries excluded
  double separationSeconds = 0.0;  // time finding and splitting off freed pieces (local search; rare)
  double collisionSeconds = 0.0;   // time in collision queries (BVH sync/refit and segment queries)
  long collisionQueries = 0;       // segment queries (one per cutting edge per sub-sample)
  long fullRefits = 0;             // whole collision trees refitted (vertices moved through object())
  long regionRefits = 0;           // trees refitted only around named vertices (verticesMoved)
  long verticesRefitted = 0;       // vertices named in those region refits
  long marginRefits = 0;           // moved trees with a collisionMargin refitted (refitMoved, no full refit)
  long marginPasses = 0;           // of those, the ones that read every vertex (the others fit in the slack)
  long verticesReanchored = 0;     // vertices those passes found past the margin (their leaves refitted)
  long fastSamples = 0;            // track samples that stayed in the pending triangle (no edit)
  long slowSamples = 0;            // track samples that walked or edited the mesh (timed)
  [[nodiscard]] double remeshMicrosPerCutTriangle() const {
    return trianglesCut > 0 ? remeshSeconds * 1e6 / static_cast<double>(trianglesCut) : 0.0;
  }
};

class CutEngine {
 public:
  explicit CutEngine(CutParams params = {});
  ~CutEngine();
  CutEngine(CutEngine&&) noexcept;
  CutEngine& operator=(CutEngine&&) noexcept;
  CutEngine(const CutEngine&) = delete;
  CutEngine& operator=(const CutEngine&) = delete;

  // Takes ownership; returns the object's id.
  int addObject(mesh::SurfaceMesh m);
  [[nodiscard]] const std::vector<TissueObject>& objects() const;
  // Throws CutError for an unknown id. Do not change the connectivity of a mesh
  // while a stroke is open on it (positions may change: physics moves vertices).
  [[nodiscard]] TissueObject& object(int id);
  // Moving vertices without the whole-tree refit that object() implies (e.g. physics
  // stepping the mesh in place): move positions of meshToMove(id), then name what moved
  // with verticesMoved(id, indices) (physics::movedVertices) before the next sample;
  // only the collision tree's boxes around those vertices are refitted (with a
  // collisionMargin, around those that left it: TriangleBvh::refitListed). Named
  // vertices are refitted also when a bound (verticesMovedWithin) comes before the
  // next sample, whichever came first. verticesMoved(id)
  // says every vertex may have moved. Do not change the connectivity. Throws CutError
  // for an unknown id or an index out of range.
  [[nodiscard]] mesh::SurfaceMesh& meshToMove(int id);
  void verticesMoved(int id, std::span<const std::uint32_t> vertices);
  void verticesMoved(int id);
  // Every vertex may have moved, none farther than maxMove per coordinate [mm] (e.g.
  // physics::Dynamics::maxMove): with a collisionMargin the tree is not even read
  // while the moves add up to less than the slack its boxes have left.
  void verticesMovedWithin(int id, double maxMove);
  // As above, for physics that sums each vertex group's moves (physics::Params::
  // travelLimit = travelLimit(id) and travelPad = travelPad(id); then pass
  // Dynamics::maxMove, groupTravel(), groupsPastLimit() and kMoveGroup, and clear the
  // list): the collision tree looks only at the listed groups and lowers their entries
  // (TriangleBvh::refitTravelled), at once (collision time), so the spans need not
  // outlive the call. Every step since the last call must have been summed; a maxMove
  // that is not finite says this one was not: as verticesMovedWithin(id, maxMove).
  // Throws CutError for groupSize 0 or an unknown id.
  void verticesTravelled(int id, double maxMove, std::span<double> travel, std::span<const std::uint32_t> past,
                         std::size_t groupSize);
  [[nodiscard]] double travelLimit(int id) const;
  [[nodiscard]] double travelPad(int id) const;
  // With tissue physics, after every sample: what the cuts added settles where its
  // springs balance (physics::settleVertices with params().tissue), on every object
  // with tissue properties, except the tracks' tips on the blade (the `from` points of
  // the sample's preview), and the collision tree hears of the moves. The first call on
  // an object only marks its vertices settled: call it once before the first sample.
  // Returns how many vertices it settled (moved).
  std::size_t settleAdded(std::span<const PreviewSegment> preview = {});

  // One sample of one hand. Scalpel edges cut on contact, L-hook edges while the
  // pedal is down, grasper jaws never (contacts only).
  StepResult step(instruments::Hand hand, instruments::Tool tool, const instruments::Pose& pose);
  // The instrument is lifted: every open cut of the hand ends where it is.
  StepResult endStroke(instruments::Hand hand);
  // Both hands.
  StepResult finish();

  [[nodiscard]] const CutStats& stats() const;
  [[nodiscard]] const CutParams& params() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ld::cutting
