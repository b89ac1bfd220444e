#include "hullpipe/collision/collision.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "hullpipe/collision/contact_region.h"

namespace hullpipe {

void AddTriangleResult(int triangle_id, const TriangleQueryResult& r, CollisionResult* result) {
  result->pixels_tested += r.pixels_tested;
  if (r.collision_points.empty()) return;
  result->triangle_ids.push_back(triangle_id);
  result->collision_points.insert(result->collision_points.end(), r.collision_points.begin(), r.collision_points.end());
  result->point_triangles.insert(result->point_triangles.end(), r.collision_points.size(), triangle_id);
}

CollisionResult DetectCollisions(const VolumeQuery& query, const TriangleMesh& mesh,
                                 const TriangleQueryOptions& options, const TriangleBatchQuery& batch,
                                 int threads) {
  options.Check();
  CollisionResult result;
  if (!mesh.Bounds().Intersects(query.hull_box())) return result;
  result.box_overlap = true;
  std::vector<Triangle> tris;
  std::vector<int> ids;
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = mesh.triangles[t];
    const Triangle T{mesh.vertices[size_t(tri[0])], mesh.vertices[size_t(tri[1])], mesh.vertices[size_t(tri[2])]};
    // Per-triangle box test: most triangles of a touching object are far away.
    Aabb tb;
    tb.Extend(T.a), tb.Extend(T.b), tb.Extend(T.c);
    if (!tb.Intersects(query.hull_box())) continue;
    tris.push_back(T);
    ids.push_back(int(t));
  }
  result.triangles_queried = int(tris.size());
  if (tris.empty()) return result;
  const std::vector<TriangleQueryResult> rs = batch ? batch(tris) : QueryTrianglesCpu(query, tris, options, threads);
  if (rs.size() != tris.size()) throw std::logic_error("DetectCollisions: batch query returned the wrong count");
  for (size_t k = 0; k < rs.size(); ++k) AddTriangleResult(ids[k], rs[k], &result);
  return result;
}

void FarthestRefineOptions::Check() const {
  if (lines_per_pixel < 1) throw std::invalid_argument("FarthestRefineOptions.lines_per_pixel must be >= 1");
  if (max_candidates < 1) throw std::invalid_argument("FarthestRefineOptions.max_candidates must be >= 1");
}

std::optional<Eigen::Vector3d> RefineFarthestCollisionPoint(const VolumeQuery& query, const TriangleMesh& mesh,
                                                            const Eigen::Vector3d& rp, const TriangleQueryOptions& o,
                                                            CollisionResult* result,
                                                            const FarthestRefineOptions& refine) {
  o.Check();
  refine.Check();
  auto& pts = result->collision_points;
  auto& owner = result->point_triangles;
  if (pts.empty() || owner.size() != pts.size()) return std::nullopt;
  std::vector<double> reach(pts.size());
  for (size_t k = 0; k < pts.size(); ++k) reach[k] = (pts[k] - rp).norm();
  std::vector<size_t> order(pts.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::sort(order.begin(), order.end(), [&](size_t x, size_t y) { return reach[x] > reach[y]; });
  const double best0 = reach[order[0]];
  double best = best0;
  std::optional<Eigen::Vector3d> found;
  int found_triangle = -1;
  std::vector<Eigen::Vector3d> done;
  for (size_t k : order) {
    if (int(done.size()) >= refine.max_candidates) break;
    const Eigen::Vector3i& ti = mesh.triangles.at(size_t(owner[k]));
    const Triangle tri{mesh.vertices[size_t(ti[0])], mesh.vertices[size_t(ti[1])], mesh.vertices[size_t(ti[2])]};
    const TriangleViewport vp = MakeTriangleViewport(tri.a, tri.b, tri.c, o);
    const double pu = vp.u_step.norm(), pv = vp.v_step.norm(), diag = std::hypot(pu, pv);
    if (reach[k] < best0 - diag) break;  // sorted: no later point can be near the farthest
    if (std::any_of(done.begin(), done.end(), [&](const Eigen::Vector3d& d) { return (d - pts[k]).norm() < diag; }))
      continue;
    done.push_back(pts[k]);
    // The candidate in viewport pixel coordinates, and a window of ±1.5 pixels.
    const Eigen::Vector3d rel = pts[k] - vp.origin;
    const double x = rel.dot(vp.u_step) / (pu * pu), y = pv > 1e-12 ? rel.dot(vp.v_step) / (pv * pv) : 0.5;
    const ViewportWindow w{x - 1.5, x + 1.5, y - 1.5, y + 1.5};
    const double spacing = std::max(std::min(pu, pv), 1e-9) / refine.lines_per_pixel;
    for (const ContactSegment& s : ExactContactSegments(query, vp, spacing, &w)) {
      for (const auto& [end, other] : {std::pair{s.p, s.q}, std::pair{s.q, s.p}}) {
        if ((end - rp).norm() <= best) continue;
        // The interval's end is the hull's exact boundary: keep a point that is
        // inside by VolumeQuery's own rounding.
        const double len = (other - end).norm();
        const Eigen::Vector3d e = query.Inside(end) || len == 0
                                      ? end
                                      : Eigen::Vector3d(end + std::min(1e-7, 0.5 * len) / len * (other - end));
        if (!query.Inside(e)) continue;
        const double d = (e - rp).norm();
        if (d > best) best = d, found = e, found_triangle = owner[k];
      }
    }
  }
  if (found) {
    pts.push_back(*found);
    owner.push_back(found_triangle);
  }
  return found;
}

}  // namespace hullpipe
