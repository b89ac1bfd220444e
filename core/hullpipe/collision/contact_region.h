// The exact intersection of a virtual triangle with the visual hull (the ground
// truth for the collision points of paper §4.1), and the error of a set of
// collision points against it.
//
// The triangle is cut by lines parallel to its longest edge, and along its three
// edges; on each line the part inside the hull is found exactly by the ray–hull
// intervals (exact_hull.h), so the region is exact along the lines and sampled
// across them. A part of the true region thinner than the line spacing, lying
// between two lines and away from the edges, can be missed: that is the
// reference's own resolution, stated with every figure.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "hullpipe/collision/triangle_query.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe {

/// A straight piece of a triangle inside the hull, end points in world metres.
struct ContactSegment {
  Eigen::Vector3d p, q;
};

/// A window of a triangle's viewport (MakeTriangleViewport), in continuous viewport
/// pixel coordinates: x in [x0, x1], y in [y0, y1].
struct ViewportWindow {
  double x0, x1, y0, y1;
};

/// The parts of the triangle of viewport `vp` (MakeTriangleViewport) inside the
/// hull of `query` (world metres), on lines across the triangle parallel to the
/// viewport's u axis (its longest edge) spaced `spacing` metres apart (the first
/// half a spacing from the triangle's edge, at least one line), within `window`
/// (nullptr: the whole triangle), and on the triangle's three edges (which reach
/// a sliver's thin ends and sharp corners no line across does). A zero-area
/// triangle is one line along its extent (and its edges). Exact along each line to 1e-12 (undistorted cameras,
/// RayHullIntervals). Throws std::invalid_argument if spacing <= 0.
std::vector<ContactSegment> ExactContactSegments(const VolumeQuery& query, const TriangleViewport& vp, double spacing,
                                                 const ViewportWindow* window = nullptr);

/// Distances between a set of collision points and an exact contact region, both
/// on one triangle (metres).
struct ContactError {
  /// Largest distance from a collision point to the region (0 when every point is
  /// inside the hull); +inf if points exist but the region is empty.
  double points_to_region = 0;
  /// Largest distance from a point of the region to the nearest collision point:
  /// how much of the contact the points leave uncovered; +inf if the region is not
  /// empty but there are no points. Sampled along each segment every `sample`
  /// metres (plus both ends), so it is low by at most sample / 2.
  double region_to_points = 0;
  /// The two-sided (Hausdorff) distance: max of the two.
  double hausdorff() const { return points_to_region > region_to_points ? points_to_region : region_to_points; }
};

/// The error of `points` (world metres, e.g. one triangle's collision points)
/// against `region` (ExactContactSegments of the same triangle). Both empty: 0.
ContactError CollisionPointError(const std::vector<Eigen::Vector3d>& points,
                                 const std::vector<ContactSegment>& region, double sample);

/// CollisionPointError's region_to_points of each of `regions` against one set of
/// points (e.g. one object's collision points against each triangle's exact
/// region), indexing the points once. 0 for an empty region; +inf for a non-empty
/// one when there are no points.
std::vector<double> UncoveredDistances(const std::vector<Eigen::Vector3d>& points,
                                       const std::vector<std::vector<ContactSegment>>& regions, double sample);

}  // namespace hullpipe
