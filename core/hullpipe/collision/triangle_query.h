// Collision detection by volume-querying a virtual triangle (paper §4.1): the
// triangle is rendered in its own small viewport by an orthographic view along its
// normal; every viewport pixel whose centre falls in the triangle is a point of the
// triangle, volume-queried against the n maps; inside pixels unproject to
// collision points in world metres.
#pragma once

#include <functional>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe {

/// Viewport sizing for the triangle query.
struct TriangleQueryOptions {
  /// Largest world length a viewport pixel may cover (metres); sets the viewport
  /// size from the triangle's size. Default 2 mm.
  double max_pixel_size = 0.002;
  /// If > 0, every triangle gets a fixed viewport of this many pixels per side
  /// (the paper used 10x10), ignoring max_pixel_size.
  int fixed_viewport = 0;
  /// Upper bound on the viewport side (pixels), so a huge triangle stays cheap.
  int max_viewport = 64;
  /// Largest viewport side either setting may ask for: 256 px (65,536 volume
  /// queries a triangle, 10x the default's worst case); 200,000 asked for
  /// 4e10 a triangle and hung the step.
  static constexpr int kMaxViewportSide = 256;
  /// Smallest max_pixel_size: 10 micrometres, far below any camera's pixel on
  /// the hull (millimetres); below it only max_viewport bounded the work.
  static constexpr double kMinPixelSize = 1e-5;
  /// Throws std::invalid_argument naming the bad field: fixed_viewport in
  /// [0, kMaxViewportSide], max_viewport in [1, kMaxViewportSide],
  /// max_pixel_size in [kMinPixelSize, 1] m (unless fixed_viewport > 0).
  void Check() const;
};

/// The orthographic viewport of one triangle: pixel (i, j) (i along u, j along v)
/// has its centre at origin + (i + 0.5) * u_step + (j + 0.5) * v_step (world m).
/// u_step and v_step are orthogonal, in the triangle's plane.
struct TriangleViewport {
  Eigen::Vector3d origin, u_step, v_step;
  int width = 0, height = 0;
  /// The triangle's vertices in viewport pixel coordinates (continuous).
  Eigen::Vector2d a2, b2, c2;
};

/// Builds the viewport of triangle (a, b, c) (world metres). The u axis follows
/// edge a->b; the box of the triangle in (u, v) is covered by width x height
/// pixels of equal size. Degenerate (zero-area) triangles get a viewport along their
/// longest edge with height 1.
TriangleViewport MakeTriangleViewport(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                      const Eigen::Vector3d& c, const TriangleQueryOptions& options);

/// True if the centre of viewport pixel (i, j) lies in the triangle (edges count
/// as inside). The rule both the CPU and the GL path use.
bool PixelInTriangle(const TriangleViewport& vp, int i, int j);

/// The triangle's chord on the line where viewport coordinate `axis` (0: x, 1: y)
/// equals `at` (continuous pixel coordinates): [*lo, *hi] in the other coordinate.
/// False if the line misses the triangle.
bool TriangleChord(const TriangleViewport& vp, int axis, double at, double* lo, double* hi);

/// One triangle for the batched queries (world metres).
struct Triangle {
  Eigen::Vector3d a, b, c;
};

/// Result of querying one triangle.
struct TriangleQueryResult {
  int pixels_tested = 0;                          ///< Pixel centres in the triangle.
  std::vector<Eigen::Vector3d> collision_points;  ///< Inside points, world metres.
};

/// CPU triangle-in-viewport volume query (the reference for the GL path). A
/// triangle thinner than a pixel (viewport height 1: a sliver or a zero-area
/// triangle) is sampled at the middle of its chord in each pixel column instead of
/// at pixel centres, so its thin ends are not skipped (the GL path sends these to
/// this function). A triangle with no sample inside it is queried at its
/// centroid, so no triangle goes untested. Each pixel is exactly
/// VolumeQuery::Inside of its centre (world metres); the centres' camera-frame
/// points are stepped affinely across the orthographic viewport, and the camera
/// that vetoed the previous pixel is asked first.
TriangleQueryResult QueryTriangleCpu(const VolumeQuery& query, const Eigen::Vector3d& a,
                                     const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                     const TriangleQueryOptions& options = {});

/// QueryTriangleCpu for many triangles, split across `threads` (>= 1) threads;
/// results in triangle order. Throws std::invalid_argument if options fail Check().
std::vector<TriangleQueryResult> QueryTrianglesCpu(const VolumeQuery& query, const std::vector<Triangle>& triangles,
                                                   const TriangleQueryOptions& options, int threads = 1);

/// A triangle query with QueryTrianglesCpu's contract run elsewhere: the GPU's
/// (gl/backend.h MakeTriangleQuery: one pass over the batch, one readback).
/// Empty: the CPU query.
using TriangleQueryFunction = std::function<std::vector<TriangleQueryResult>(
    const VolumeQuery& query, const std::vector<Triangle>& triangles, const TriangleQueryOptions& options)>;

/// Point queries for particles (paper §4.1: a particle is a point, so it needs no
/// viewport): inside[k] != 0 iff points[k] (world metres) is inside the hull
/// (VolumeQuery::Inside, after the hull-box test).
std::vector<char> QueryPoints(const VolumeQuery& query, const std::vector<Eigen::Vector3d>& points);

}  // namespace hullpipe
