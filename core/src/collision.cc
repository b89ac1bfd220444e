#include "hullpipe/collision.h"

namespace hullpipe {

CollisionResult DetectCollisions(const VolumeQuery& query, const TriangleMesh& mesh,
                                 const TriangleQueryOptions& options) {
  options.Check();
  CollisionResult result;
  if (!mesh.Bounds().Intersects(query.hull_box())) return result;
  result.box_overlap = true;
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = mesh.triangles[t];
    const auto& a = mesh.vertices[size_t(tri[0])];
    const auto& b = mesh.vertices[size_t(tri[1])];
    const auto& c = mesh.vertices[size_t(tri[2])];
    // Per-triangle box test: most triangles of a touching object are far away.
    Aabb tb;
    tb.Extend(a), tb.Extend(b), tb.Extend(c);
    if (!tb.Intersects(query.hull_box())) continue;
    ++result.triangles_queried;
    TriangleQueryResult r = QueryTriangleCpu(query, a, b, c, options);
    result.pixels_tested += r.pixels_tested;
    if (!r.collision_points.empty()) {
      result.triangle_ids.push_back(int(t));
      result.collision_points.insert(result.collision_points.end(), r.collision_points.begin(),
                                     r.collision_points.end());
    }
  }
  return result;
}

}  // namespace hullpipe
