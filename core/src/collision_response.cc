#include "hullpipe/collision_response.h"

#include "hullpipe/exact_hull.h"

namespace hullpipe {

std::optional<CollisionResponse> ComputeResponse(const VolumeQuery& query,
                                                 const std::vector<Eigen::Vector3d>& collision_points,
                                                 const Eigen::Vector3d& rp_obj,
                                                 const std::optional<Eigen::Vector3d>& v_rec_given,
                                                 const ResponseOptions& options) {
  options.Check();
  if (collision_points.empty()) return std::nullopt;
  CollisionResponse r;
  double far2 = -1;
  for (const auto& p : collision_points) {
    const double d2 = (p - rp_obj).squaredNorm();
    if (d2 > far2) far2 = d2, r.cp_obj = p;
  }
  const double reach = std::sqrt(far2);
  constexpr double kTiny = 1e-9;
  if (v_rec_given && v_rec_given->norm() > kTiny) {
    r.v_rec = v_rec_given->normalized();
  } else if (reach > kTiny) {
    r.v_rec = (rp_obj - r.cp_obj) / reach;
  } else {
    r.v_rec_fallback = true;
    const Eigen::Vector3d away = rp_obj - query.hull_box().Center();
    r.v_rec = !query.hull_box().empty() && away.norm() > kTiny ? Eigen::Vector3d(away.normalized())
                                                                : Eigen::Vector3d(0, 0, -1);
  }
  // Search from RP_obj's side (at least 1 mm out) back toward CP_obj.
  const double length = std::max(reach, 1e-3);
  const Eigen::Vector3d origin = r.cp_obj + length * r.v_rec;
  const Intervals iv = RayHullIntervals(query, origin, -r.v_rec, 0.0, length);
  if (iv.empty()) return std::nullopt;
  r.cp_hull = origin - iv.front().first * r.v_rec;
  r.d_rec = (r.cp_hull - r.cp_obj).norm();
  const auto n = iv.front().first > 0 ? HullSurfaceNormal(query, r.cp_hull, options.normal) : std::nullopt;
  if (n) {
    r.n_hull = n->normal;
    r.n_hull_edge = n->edge;
  } else {
    r.n_hull = r.v_rec;
    r.n_hull_fallback = true;
  }
  return r;
}

}  // namespace hullpipe
