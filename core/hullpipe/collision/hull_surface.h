// The visual hull's surface near a point, by exact means (groundwork for the
// collision response of paper §4): the first hull point along a search
// direction (CP_hull) from the exact ray–hull intervals, and the hull's surface
// normal (N_hull) from the silhouette edge that forms the surface there.
//
// The hull is the intersection of the cameras' silhouette cones, so at a surface
// point X the surface lies on the cone of (at least) one camera c: X projects onto
// the border of c's object pixels. The cone's tangent plane at X contains camera
// c's centre and the back-projection of the silhouette contour's tangent at X's
// projection, so its normal is exact up to how well the contour's direction is
// known from the pixels (a line fitted to the border pixels within a few pixels).
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe {

/// The first hull point met along origin + s * dir (world metres; dir need not be
/// unit) for s in [0, s_max]: the start of the first exact ray–hull interval
/// (RayHullIntervals). CP_hull of §4 when origin is on RP_obj's side and dir points
/// toward CP_obj. nullopt if the segment meets no hull.
std::optional<Eigen::Vector3d> FirstHullPointAlong(const VolumeQuery& query, const Eigen::Vector3d& origin,
                                                   const Eigen::Vector3d& dir, double s_max);

/// The first point along origin + s * dir (world metres; dir need not be unit,
/// s in its units) for s in [s_begin, s_end] whose point query
/// (VolumeQuery::Inside) is `inside`: origin + s_begin * dir first, then samples
/// at most `step` metres apart, then bisection between the last sample of the
/// other kind and the first of this kind until they are `tolerance` metres apart.
/// Returns that s (on the `inside` side), or nullopt if no sample is of this
/// kind. A stretch of this kind shorter than `step` may lie between samples and
/// be missed. By point queries: cheaper than FirstHullPointAlong's exact
/// intervals, above all with lens distortion. Used for entering the hull
/// (particles) and leaving it (PushOutAlong).
std::optional<double> FirstSampledCrossing(const VolumeQuery& query, const Eigen::Vector3d& origin,
                                           const Eigen::Vector3d& dir, double s_begin, double s_end, bool inside,
                                           double step, double tolerance);

/// Settings of HullSurfaceNormal.
struct HullNormalOptions {
  /// A camera forms the surface at X if X's projection is within this many pixels
  /// of its silhouette border (object/background pixel edge).
  double border_px = 1.0;
  /// Radius (pixels) of border pixels used to fit the contour's direction.
  int fit_radius_px = 6;
  /// Throws std::invalid_argument naming the bad field.
  void Check() const;
};

/// N_hull at a hull surface point and where it came from.
struct HullNormal {
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< Outward unit normal, world frame.
  int camera = -1;          ///< Index in query.views() of the camera whose cone it is.
  double border_px = 0;     ///< Distance of X's projection from that border, pixels.
  /// True when two or more cameras' borders pass within border_px (X on a hull
  /// edge or corner, where the normal is undefined): then `normal` is the
  /// normalized sum of their cone normals, a documented fallback that points
  /// outward from every cone involved.
  bool edge = false;
  /// Every camera whose border passes within border_px (indices in
  /// query.views()): `camera` alone off edges.
  std::vector<int> cameras;
};

/// The hull's outward surface normal at X (world metres), which should lie on the
/// hull's surface (e.g. from FirstHullPointAlong). nullopt if no camera's border
/// passes within options.border_px of X's projection (X is not on the surface).
std::optional<HullNormal> HullSurfaceNormal(const VolumeQuery& query, const Eigen::Vector3d& X_world,
                                            const HullNormalOptions& options = {});

}  // namespace hullpipe
