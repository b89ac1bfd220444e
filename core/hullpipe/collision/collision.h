// Collision detection between virtual objects and the visual hull (paper §4.1):
// a bounding-box test first, then every triangle of a candidate object is
// volume-queried in its own viewport (triangle_query.h).
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/geometry/mesh.h"
#include "hullpipe/collision/triangle_query.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe {

/// What colliding a mesh with the hull found (FCL-style result struct).
struct CollisionResult {
  bool box_overlap = false;                         ///< Passed the bounding-box test.
  std::vector<int> triangle_ids;                    ///< Triangles with collision points.
  std::vector<Eigen::Vector3d> collision_points;    ///< CP_i, world metres.
  std::vector<int> point_triangles;                 ///< The mesh triangle of each CP_i.
  int triangles_queried = 0;
  int pixels_tested = 0;
  bool colliding() const { return !collision_points.empty(); }
};

/// Adds one queried triangle's result to *result: its pixels tested and, when
/// it has collision points, the triangle id, its points and their owner (the
/// layout DetectCollisions gives). triangles_queried is the caller's.
void AddTriangleResult(int triangle_id, const TriangleQueryResult& r, CollisionResult* result);

/// Queries a batch of triangles (world metres) against the hull, results in
/// triangle order (QueryTrianglesCpu, or gl::GlTriangleQuery::Query bound to its
/// query and options).
using TriangleBatchQuery = std::function<std::vector<TriangleQueryResult>(const std::vector<Triangle>&)>;

/// Detects collisions of a mesh in world coordinates with the hull of `query`:
/// if the mesh's box misses the hull's box no triangle is queried; otherwise every
/// triangle whose own box meets the hull box is queried, by `batch` if given, else
/// by QueryTrianglesCpu with `threads` threads. Throws std::invalid_argument if
/// options fail Check().
CollisionResult DetectCollisions(const VolumeQuery& query, const TriangleMesh& world_mesh,
                                 const TriangleQueryOptions& options = {}, const TriangleBatchQuery& batch = {},
                                 int threads = 1);

/// Settings of RefineFarthestCollisionPoint.
struct FarthestRefineOptions {
  /// Lines per viewport pixel across the window around a candidate: the refined
  /// CP_obj is exact along each line, so its error is about pixel / lines_per_pixel.
  int lines_per_pixel = 16;
  /// Candidates examined: the collision points farthest from RP_obj, at most this
  /// many, skipping any within a pixel of one already examined.
  int max_candidates = 8;
  /// Throws std::invalid_argument naming the bad field.
  void Check() const;
};

/// Refines CP_obj (paper §4.2: the collision point farthest from RP_obj) below
/// the viewport's pixel: around each candidate (collision points whose distance
/// from RP_obj is within a pixel diagonal of the farthest), the candidate's
/// triangle is cut by lines at pixel / lines_per_pixel spacing over a window of
/// ±1.5 pixels, and each line's part inside the hull found exactly
/// (ExactContactSegments). The farthest of those exact points from RP_obj is
/// appended to result->collision_points (with its triangle) if it is farther than
/// every existing point, and returned; nullopt (and no change) otherwise. Every
/// point it adds passes VolumeQuery::Inside and lies on the triangle (an exact
/// boundary point that rounds outside is moved 0.1 µm into its segment). `options` must be the
/// detection's (they fix the viewports). A contact region wholly between pixel
/// centres is not found (the detection did not see it).
std::optional<Eigen::Vector3d> RefineFarthestCollisionPoint(const VolumeQuery& query, const TriangleMesh& world_mesh,
                                                            const Eigen::Vector3d& rp_obj,
                                                            const TriangleQueryOptions& options,
                                                            CollisionResult* result,
                                                            const FarthestRefineOptions& refine = {});

}  // namespace hullpipe
