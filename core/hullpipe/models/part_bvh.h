// Collision and proximity of a large rigid part with the visual hull (paper
// §4.1 at the size of real CAD models, and §4.5's proximity): a bounding volume
// hierarchy over the part's triangles, built once at load in the part's body
// frame. Each frameset it is descended against the hull: a node whose box the
// cameras prove empty of hull (VolumeQuery::ProvesEmpty, the hull box search's
// rule) is skipped with all its triangles; the triangle query (§4.1) runs on the
// triangles left, so the result equals testing every triangle.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "hullpipe/collision/collision.h"
#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/mesh.h"
#include "hullpipe/geometry/rigid3.h"
#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe {

/// A binary hierarchy of axis-aligned boxes over a mesh's triangles (body
/// frame metres). Immutable once built.
class TriangleBvh {
 public:
  struct Node {
    Aabb box;        ///< Of every triangle below, body frame.
    int first = 0;   ///< Leaf: its triangles are order()[first, first + count).
    int count = 0;   ///< 0: an inner node, children left and left + 1... see `left`.
    int left = -1;   ///< Inner node: index of its first child; the second follows it.
  };
  TriangleBvh() = default;
  /// Builds over `mesh` (body frame): each node splits its triangles at the median
  /// centroid along its box's longest axis, down to `leaf_size` triangles.
  /// Throws std::invalid_argument if leaf_size < 1 or an index is out of range.
  explicit TriangleBvh(const TriangleMesh& mesh, int leaf_size = 8);

  const std::vector<Node>& nodes() const { return nodes_; }
  const std::vector<int>& order() const { return order_; }
  bool empty() const { return nodes_.empty(); }

  /// The triangles (ids into the mesh, increasing) in leaves that the hull may
  /// reach: every node's box, moved by world_from_body, is tested with
  /// VolumeQuery::ProvesEmpty and a proven node is skipped. *boxes_tested
  /// (optional) counts the boxes tested. A triangle not returned has no point
  /// inside the hull.
  std::vector<int> Candidates(const VolumeQuery& query, const Rigid3d& world_from_body, bool identity,
                              int64_t* boxes_tested = nullptr) const;

  /// Least distance (metres) from p_body to the mesh's triangles, if below
  /// `bound`; else returns `bound`. *closest (optional) gets the nearest mesh
  /// point, body frame, and *triangle (optional) its triangle's index, when
  /// found.
  double Distance(const TriangleMesh& mesh, const Eigen::Vector3d& p_body, double bound,
                  Eigen::Vector3d* closest = nullptr, int* triangle = nullptr) const;

 private:
  std::vector<Node> nodes_;
  std::vector<int> order_;
};

/// The point of triangle (a, b, c) nearest p (Ericson, Real-Time Collision
/// Detection §5.1.5); exact for degenerate triangles too.
Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c);

/// The box of `box` moved by T (the box of its 8 corners moved).
Aabb TransformBox(const Rigid3d& T, const Aabb& box);

/// What one frameset's descent and query cost (stats.json, "models").
struct BvhQueryStats {
  int64_t triangles_in_scene = 0;  ///< Triangles of every part.
  int64_t boxes_tested = 0;        ///< Hierarchy nodes tested against the hull.
  int64_t triangles_queried = 0;   ///< Triangles volume-queried (§4.1 viewports).
  void Add(const BvhQueryStats& o) {
    triangles_in_scene += o.triangles_in_scene, boxes_tested += o.boxes_tested,
        triangles_queried += o.triangles_queried;
  }
};

/// The triangles DetectCollisionsBvh queries: the hierarchy's candidates
/// (Candidates, moved by world_from_body to world metres) whose own box meets
/// the hull box, appended to *triangles with their mesh ids to *ids, in
/// increasing id. *stats (optional) gets the boxes tested and the triangles
/// appended (triangles_queried).
void GatherBvhTriangles(const VolumeQuery& query, const TriangleMesh& body_mesh, const TriangleBvh& bvh,
                        const Rigid3d& world_from_body, std::vector<Triangle>* triangles, std::vector<int>* ids,
                        BvhQueryStats* stats = nullptr);

/// DetectCollisions (collision.h) through the hierarchy: the same triangles
/// with collision points and the same points, in the same order, as
/// DetectCollisions of the mesh moved by world_from_body. `batch`: as in
/// DetectCollisions (nullptr: the CPU query on `threads` threads).
CollisionResult DetectCollisionsBvh(const VolumeQuery& query, const TriangleMesh& body_mesh, const TriangleBvh& bvh,
                                    const Rigid3d& world_from_body, const TriangleQueryOptions& options = {},
                                    const TriangleBatchQuery& batch = {}, int threads = 1,
                                    BvhQueryStats* stats = nullptr);

}  // namespace hullpipe

namespace hullpipe {

/// A part's least distance from the hull (paper §4.5: "volume-querying with
/// distance fields returns proximity information").
struct PartClearance {
  double distance = 0;     ///< Metres; max_clearance when no hull is nearer.
  bool hull_near = false;  ///< A hull sample lies within max_clearance.
  Eigen::Vector3d hull_point = Eigen::Vector3d::Zero();  ///< The hull sample nearest the part (world).
};

// HullSamples and SampleHull (the coarse samples several parts' clearances
// share) are in reconstruction/exact_hull.h.

/// Least distance from the hull of `query` to the part's triangles (moved by
/// world_from_body) up to max_clearance: each coarse sample within
/// max_clearance of the part's box gets its exact distance to the triangles
/// through the hierarchy; around the nearest, six grids each twice as fine
/// (±1 step of the grid before: 125 points each) refine it. The result is never below the
/// distance of the hull (it is a distance to a hull point), and above it by at
/// most half the finest grid's diagonal (step / 64 * sqrt(3) / 2: 0.27 mm at
/// 2 cm), unless a hull part thinner than `step`, or more than one step from
/// the nearest coarse sample, lies nearer. It measures distance to the
/// surface: a hull wholly inside a closed part is found by the triangle query,
/// not here. `coarse` must cover the part's box grown by max_clearance. Only a
/// coarse distance below `refine_below` is refined (default: every one); one
/// above it is the coarse sample's, at most step * sqrt(3) / 2 above the
/// hull's distance (same provisos).
PartClearance HullToPartClearance(const VolumeQuery& query, const TriangleMesh& body_mesh, const TriangleBvh& bvh,
                                  const Rigid3d& world_from_body, double max_clearance, const HullSamples& coarse,
                                  double refine_below = 1e300);
/// The same, sampling the hull itself over the part's box grown by max_clearance.
PartClearance HullToPartClearance(const VolumeQuery& query, const TriangleMesh& body_mesh, const TriangleBvh& bvh,
                                  const Rigid3d& world_from_body, double max_clearance, double step = 0.02);

}  // namespace hullpipe
