// Collision detection between virtual objects and the visual hull (paper §4.1):
// a bounding-box test first, then every triangle of a candidate object is
// volume-queried in its own viewport (triangle_query.h).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "hullpipe/mesh.h"
#include "hullpipe/triangle_query.h"
#include "hullpipe/volume_query.h"

namespace hullpipe {

/// What colliding a mesh with the hull found (FCL-style result struct).
struct CollisionResult {
  bool box_overlap = false;                         ///< Passed the bounding-box test.
  std::vector<int> triangle_ids;                    ///< Triangles with collision points.
  std::vector<Eigen::Vector3d> collision_points;    ///< CP_i, world metres.
  int triangles_queried = 0;
  int pixels_tested = 0;
  bool colliding() const { return !collision_points.empty(); }
};

/// Detects collisions of a mesh in world coordinates with the hull of `query`.
/// If the mesh's box misses the hull's box no triangle is queried.
CollisionResult DetectCollisions(const VolumeQuery& query, const TriangleMesh& world_mesh,
                                 const TriangleQueryOptions& options = {});

}  // namespace hullpipe
