// The collision response quantities of paper §4 (Lok et al. 2003, §4.2) for one
// virtual object that collided with the visual hull, by exact means: CP_hull from
// the exact ray–hull intervals, N_hull from the silhouette edge that forms the hull
// (hull_surface.h). Frames: world metres throughout.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/collision/collision.h"
#include "hullpipe/collision/hull_motion.h"
#include "hullpipe/collision/hull_surface.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe {

/// Settings of ComputeResponse.
struct ResponseOptions {
  HullNormalOptions normal;  ///< How N_hull is found.
  /// Throws std::invalid_argument naming the bad field.
  void Check() const { normal.Check(); }
};

/// The §4 response of one object (FCL-style result struct).
struct CollisionResponse {
  Eigen::Vector3d cp_obj = Eigen::Vector3d::Zero();   ///< Collision point farthest from RP_obj.
  Eigen::Vector3d v_rec = Eigen::Vector3d::Zero();    ///< Unit recovery direction.
  Eigen::Vector3d cp_hull = Eigen::Vector3d::Zero();  ///< First hull point from RP_obj's side toward CP_obj.
  double d_rec = 0;                                   ///< |CP_hull - CP_obj|, metres.
  Eigen::Vector3d n_hull = Eigen::Vector3d::Zero();   ///< Outward unit hull normal at CP_hull.
  /// V_rec had zero length (CP_obj == RP_obj): it was taken from the hull box's
  /// centre toward RP_obj instead (or world -z, up in the rigs' z-down frames, if
  /// those coincide too), and ComputeResponse searches for CP_hull from where
  /// V_rec leaves the hull box (ComputeResponsePaper: its usual 5 cm).
  bool v_rec_fallback = false;
  /// No silhouette border near CP_hull (e.g. RP_obj itself inside the hull, so
  /// CP_hull is RP_obj): n_hull is V_rec.
  bool n_hull_fallback = false;
  /// CP_hull on a hull edge or corner: n_hull is the documented blend
  /// (HullNormal::edge).
  bool n_hull_edge = false;
  /// The hull surface's normal velocity at CP_hull (hull_motion.h): set by
  /// RespondAsRigidBody when given the hull's motion; kNone otherwise.
  HullVelocity hull_velocity;
};

/// §4.2: CP_obj is the collision point farthest from the object's reference point
/// RP_obj; V_rec points from CP_obj toward RP_obj unless the simulation gives it
/// (`v_rec_given`, e.g. a cloth vertex's normal; normalized here); CP_hull is the
/// first point inside the hull met searching from CP_obj + |RP_obj - CP_obj| V_rec
/// (RP_obj itself when V_rec is not given) back toward CP_obj (exact intervals);
/// D_rec = |CP_hull - CP_obj|: translating the object by D_rec V_rec puts CP_obj on
/// the hull's surface; N_hull is the hull's normal there. nullopt if there are no
/// collision points, or CP_hull cannot be found (CP_obj not inside the hull).
std::optional<CollisionResponse> ComputeResponse(const VolumeQuery& query,
                                                 const std::vector<Eigen::Vector3d>& collision_points,
                                                 const Eigen::Vector3d& rp_obj,
                                                 const std::optional<Eigen::Vector3d>& v_rec_given = std::nullopt,
                                                 const ResponseOptions& options = {});

/// Settings of the paper's triangle scan (§4.2), kept to compare with the exact
/// method.
struct PaperResponseOptions {
  double apex_deg = 10.0;  ///< Apex angle of the isosceles search triangles.
  double length = 0.05;    ///< Their height along V_rec, metres (5 cm).
  double pixel = 0.001;    ///< Sample spacing in the triangles' planes, metres.
  /// Throws std::invalid_argument naming the bad field.
  void Check() const;
};

/// The same quantities found as the paper does, by volume-querying two
/// perpendicular isosceles triangles with their apex at CP_obj and their axis
/// along V_rec: scanning each from its base (RP_obj's side) toward the apex, the
/// first inside sample on the axis gives CP_hull (to within `pixel`), and a line
/// fitted to the first inside sample of every column gives a tangent of the hull
/// in each triangle's plane; N_hull is their cross product, turned outward (toward
/// V_rec). Where a triangle has fewer than two columns with a boundary, N_hull is
/// V_rec and n_hull_fallback is set. Same nullopt cases as ComputeResponse, and
/// also when the hull's surface along the axis is not within the triangles (the
/// base is already inside: CP_hull is farther than `length` from CP_obj).
std::optional<CollisionResponse> ComputeResponsePaper(const VolumeQuery& query,
                                                      const std::vector<Eigen::Vector3d>& collision_points,
                                                      const Eigen::Vector3d& rp_obj,
                                                      const std::optional<Eigen::Vector3d>& v_rec_given = std::nullopt,
                                                      const PaperResponseOptions& options = {});

/// What RespondAsRigidBody needs besides the hull and the collision (as FCL's
/// request structs). Frames: world, metres, m/s.
struct RigidBodyResponseRequest {
  /// Exact response: CP_obj refined on these triangles (the body's in the world,
  /// numbered as the collision result numbers them). Unused by the paper's scans.
  const TriangleMesh* world_mesh = nullptr;
  Eigen::Vector3d rp_obj = Eigen::Vector3d::Zero();  ///< A reference point inside the body (its centre).
  TriangleQueryOptions query;  ///< The triangle query's settings (the exact CP_obj's refinement).
  bool exact = true;           ///< Exact CP_hull and N_hull, or the paper's triangle scans.
  double restitution = 0.5;    ///< e in [0, 1]: the normal speed kept, reflected.
  /// The tracked point's position before the substep: where it goes back to
  /// when there is no CP_hull.
  Eigen::Vector3d previous = Eigen::Vector3d::Zero();
  /// Unit normal used where the collision points' centroid coincides with rp_obj.
  Eigen::Vector3d fallback_normal = Eigen::Vector3d::UnitZ();
  /// The previous frameset's hull (hull_motion.h), or null for a stationary hull.
  const HullMotion* motion = nullptr;
};

/// §4.2 applied to a translating rigid body (a ball, a dynamic CAD part) whose
/// substep ended in collision *c. CP_obj (the collision point farthest from
/// rp_obj) and then CP_hull and N_hull: exactly (`exact`:
/// RefineFarthestCollisionPoint on *world_mesh, then ComputeResponse), or by the
/// paper's triangle scans (ComputeResponsePaper). The body moves by D_rec along
/// V_rec plus 1 mm, so CP_obj ends 1 mm clear of the hull's surface (*position
/// moves by that vector: it may be any point fixed to the body, as a part's pose
/// translation), and the part of *velocity into the hull, v . N_hull < 0, is
/// reflected about N_hull scaled by `restitution` (v -= (1 + e) (v . N) N).
/// Given `motion`, the velocity reflected is the body's relative to the hull's
/// surface at CP_hull (ReflectOffMovingSurface; the estimate is kept in the
/// response's hull_velocity), so a moving hand throws what it strikes; a
/// stationary hull gives the same result as without. Without a CP_hull (a
/// collision point outside the hull by rounding) *position goes back to
/// `previous` and the normal is the direction from the collision points'
/// centroid to rp_obj, or fallback_normal where they coincide. Returns the
/// response (nullopt in that fallback). *c gains the refined point (exact).
/// Throws std::invalid_argument if `exact` and world_mesh is null.
std::optional<CollisionResponse> RespondAsRigidBody(const VolumeQuery& query, const RigidBodyResponseRequest& request,
                                                    CollisionResult* c, Eigen::Vector3d* position,
                                                    Eigen::Vector3d* velocity);

}  // namespace hullpipe
