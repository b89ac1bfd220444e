#include "hullpipe/collision/collision_response.h"

#include "hullpipe/reconstruction/exact_hull.h"

#include <cmath>
#include <stdexcept>

namespace hullpipe {

namespace {

constexpr double kTiny = 1e-9;

// CP_obj and V_rec (with its fallback); *reach = |RP_obj - CP_obj|.
CollisionResponse ObjectSide(const VolumeQuery& query, const std::vector<Eigen::Vector3d>& collision_points,
                             const Eigen::Vector3d& rp_obj, const std::optional<Eigen::Vector3d>& v_rec_given,
                             double* reach) {
  CollisionResponse r;
  double far2 = -1;
  for (const auto& p : collision_points) {
    const double d2 = (p - rp_obj).squaredNorm();
    if (d2 > far2) far2 = d2, r.cp_obj = p;
  }
  *reach = std::sqrt(far2);
  if (v_rec_given && v_rec_given->norm() > kTiny) {
    r.v_rec = v_rec_given->normalized();
  } else if (*reach > kTiny) {
    r.v_rec = (rp_obj - r.cp_obj) / *reach;
  } else {
    r.v_rec_fallback = true;
    const Eigen::Vector3d away = rp_obj - query.hull_box().Center();
    r.v_rec = !query.hull_box().empty() && away.norm() > kTiny ? Eigen::Vector3d(away.normalized())
                                                                : Eigen::Vector3d(0, 0, -1);
  }
  return r;
}

}  // namespace

std::optional<CollisionResponse> ComputeResponse(const VolumeQuery& query,
                                                 const std::vector<Eigen::Vector3d>& collision_points,
                                                 const Eigen::Vector3d& rp_obj,
                                                 const std::optional<Eigen::Vector3d>& v_rec_given,
                                                 const ResponseOptions& options) {
  options.Check();
  if (collision_points.empty()) return std::nullopt;
  double reach = 0;
  CollisionResponse r = ObjectSide(query, collision_points, rp_obj, v_rec_given, &reach);
  // Search from RP_obj's side (at least 1 mm out) back toward CP_obj. With no
  // V_rec from the object (CP_obj == RP_obj) the object gives no reach either:
  // search from where V_rec leaves the hull box.
  double length = std::max(reach, 1e-3);
  if (r.v_rec_fallback) {
    double s0 = 0, s1 = 1e9;
    if (query.hull_box().ClipRay(r.cp_obj, r.v_rec, &s0, &s1)) length = std::max(length, s1 + 1e-3);
  }
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

void PaperResponseOptions::Check() const {
  if (!(apex_deg > 0 && apex_deg < 180))
    throw std::invalid_argument("PaperResponseOptions.apex_deg must be in (0, 180)");
  if (!(length > 0)) throw std::invalid_argument("PaperResponseOptions.length must be > 0");
  if (!(pixel > 0 && pixel < length)) throw std::invalid_argument("PaperResponseOptions.pixel must be in (0, length)");
}

std::optional<CollisionResponse> ComputeResponsePaper(const VolumeQuery& query,
                                                      const std::vector<Eigen::Vector3d>& collision_points,
                                                      const Eigen::Vector3d& rp_obj,
                                                      const std::optional<Eigen::Vector3d>& v_rec_given,
                                                      const PaperResponseOptions& options) {
  options.Check();
  if (collision_points.empty()) return std::nullopt;
  double reach = 0;  // not needed: the paper searches a fixed length
  CollisionResponse r = ObjectSide(query, collision_points, rp_obj, v_rec_given, &reach);
  // Two directions across V_rec: the triangles' planes are (V_rec, e1), (V_rec, e2).
  const Eigen::Vector3d a = r.v_rec;
  const Eigen::Vector3d helper = std::abs(a.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d e1 = a.cross(helper).normalized(), e2 = a.cross(e1);
  const double h = options.pixel, half_tan = std::tan(0.5 * options.apex_deg * M_PI / 180.0);
  const int rows = int(std::ceil(options.length / h));
  // Scans one triangle: returns the axis entry distance from the apex (or -1) and
  // the tangent across, from the first inside sample of each column.
  auto scan = [&](const Eigen::Vector3d& across, double* axis_s, std::optional<Eigen::Vector3d>* tangent) {
    *axis_s = -1;
    const int cols = int(std::ceil(options.length * half_tan / h));
    std::vector<std::pair<double, double>> boundary;  // (offset across, distance from apex)
    for (int c = -cols; c <= cols; ++c) {
      const double x = c * h;
      for (int k = rows - 1; k >= 0; --k) {  // from the base toward the apex
        const double sd = (k + 0.5) * h;
        if (std::abs(x) > sd * half_tan) continue;  // outside the triangle
        if (query.Inside(r.cp_obj + sd * a + x * across)) {
          // Inside at the base: the surface is beyond the triangle, not in it.
          if (k == rows - 1) break;
          boundary.emplace_back(x, sd);
          if (c == 0) *axis_s = sd;
          break;
        }
      }
    }
    if (boundary.size() >= 2) {
      // Least-squares line sd = p + q x through the boundary samples.
      double sx = 0, ss = 0, sxx = 0, sxs = 0;
      for (const auto& [x, sd] : boundary) sx += x, ss += sd, sxx += x * x, sxs += x * sd;
      const double n = double(boundary.size()), den = n * sxx - sx * sx;
      if (std::abs(den) > 1e-18) {
        const double q = (n * sxs - sx * ss) / den;
        *tangent = Eigen::Vector3d((across + q * a).normalized());
      }
    }
  };
  double s1 = -1, s2 = -1;  // the second triangle's axis is the same line
  std::optional<Eigen::Vector3d> t1, t2;
  scan(e1, &s1, &t1);
  scan(e2, &s2, &t2);
  if (s1 < 0) s1 = s2;
  if (s1 < 0) return std::nullopt;  // no hull on the axis within `length`
  r.cp_hull = r.cp_obj + s1 * a;
  r.d_rec = s1;
  if (t1 && t2) {
    Eigen::Vector3d n = t1->cross(*t2);
    if (n.norm() > kTiny) {
      n.normalize();
      r.n_hull = n.dot(a) >= 0 ? n : Eigen::Vector3d(-n);
      return r;
    }
  }
  r.n_hull = a;
  r.n_hull_fallback = true;
  return r;
}

std::optional<CollisionResponse> RespondAsRigidBody(const VolumeQuery& query, const RigidBodyResponseRequest& request,
                                                    CollisionResult* c, Eigen::Vector3d* position,
                                                    Eigen::Vector3d* velocity) {
  const Eigen::Vector3d& rp_obj = request.rp_obj;
  std::optional<CollisionResponse> resp;
  if (request.exact) {
    if (!request.world_mesh) throw std::invalid_argument("RespondAsRigidBody: an exact response needs world_mesh");
    RefineFarthestCollisionPoint(query, *request.world_mesh, rp_obj, request.query, c);
    resp = ComputeResponse(query, c->collision_points, rp_obj);
  } else {
    resp = ComputeResponsePaper(query, c->collision_points, rp_obj);
  }
  Eigen::Vector3d n;
  HullVelocity hull_velocity;  // none: the paper's stationary hull
  if (resp) {
    n = resp->n_hull;
    if (request.motion) resp->hull_velocity = hull_velocity = request.motion->At(resp->cp_hull, resp->n_hull);
    *position += (resp->d_rec + 1e-3) * resp->v_rec;  // 1 mm clear of the surface
  } else {
    // No CP_hull (a collision point outside the hull by float rounding): back
    // out to the previous position, pushing away from the points' centroid.
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const auto& p : c->collision_points) centroid += p;
    centroid /= double(c->collision_points.size());
    n = rp_obj - centroid;
    n = n.norm() > 1e-9 ? Eigen::Vector3d(n.normalized()) : request.fallback_normal;
    *position = request.previous;
  }
  ReflectOffMovingSurface(n, hull_velocity, request.restitution, velocity);
  return resp;
}

}  // namespace hullpipe
