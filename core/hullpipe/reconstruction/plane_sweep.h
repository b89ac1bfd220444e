// Rendering the visual hull for a novel view by plane sweep (paper §3.3).
// Planes perpendicular to the view's optical axis are swept front to back through
// the view frustum; on each plane every pixel's point is volume-queried against
// the n maps (the GL path counts with the stencil buffer); the first plane where
// a pixel's count is n gives its depth.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "hullpipe/geometry/rigid3.h"
#include "hullpipe/reconstruction/volume_query.h"
#include "hullpipe/util/interrupt.h"

namespace hullpipe {

/// The user's (novel) view: an undistorted pinhole camera, hullpipe pixels.
struct NovelView {
  int width = 320, height = 240;
  double fx = 300, fy = 300, cx = 160, cy = 120;
  Rigid3d world_from_eye;  ///< Eye pose; eye frame is OpenCV's (x right, y down, z fwd).

  /// Throws std::invalid_argument on a non-positive size or focal length.
  void Check() const;
  /// A view of the given size with a horizontal field of view (radians), principal
  /// point at the image centre.
  static NovelView FromFov(int width, int height, double hfov_rad, const Rigid3d& world_from_eye);
  /// Eye-frame direction of pixel (u, v) scaled so that its z is 1.
  Eigen::Vector3d EyeRay(double u, double v) const {
    return {(u - cx) / fx, (v - cy) / fy, 1.0};
  }
};

/// How the sweep places its planes between near and far.
enum class PlaneSpacing { kUniformDepth, kUniformInverseDepth };

/// Plane sweep settings.
struct PlaneSweepOptions {
  /// More planes than this buy nothing (at 4096 the spacing is under 1 mm over a
  /// 4 m range, below the maps' pixel footprint) and only stall the node.
  static constexpr int kMaxPlanes = 4096;
  int num_planes = 50;      ///< Planes between near and far, [2, kMaxPlanes]; with refinement 50 beat 100 unrefined.
  double near = 0.05;       ///< Nearest plane, eye z in metres (> 0).
  double far = 50.0;        ///< Farthest plane, eye z in metres (> near).
  PlaneSpacing spacing = PlaneSpacing::kUniformDepth;
  /// Narrow [near, far] to the hull's bounding box seen from the eye, so all planes
  /// fall where the hull can be (the frustum part in front of or behind the box has
  /// no hull). Same planes for every backend.
  bool fit_planes_to_hull_box = true;
  /// Throws std::invalid_argument naming the bad field.
  void Check() const;
};

/// The eye-z depths (metres, ascending) of the sweep's planes for this view and
/// frameset. Empty when the hull box is empty or entirely outside [near, far].
std::vector<double> SweepPlaneDepths(const VolumeQuery& query, const NovelView& view,
                                     const PlaneSweepOptions& options);

/// Counters of a sweep (for benchmarks).
struct SweepStats {
  /// Pixels whose ray met the hull box where the empty space (EmptySpace)
  /// leaves room for the hull.
  int64_t rays = 0;
  int64_t plane_points = 0;  ///< Plane points visited.
  int64_t projections = 0;   ///< Point-in-camera tests made.
  int64_t skipped = 0;       ///< Point queries answered by the empty-space grid (EmptySpace), no camera asked.
  /// Near misses whose scan was skipped: their vetoing camera vetoes the whole
  /// bracket (VolumeQueryOptions::prune_near_misses).
  int64_t pruned = 0;
  /// Plane points skipped in runs that one camera puts on background, their
  /// brackets included (VolumeQueryOptions::skip_background_runs); counted in
  /// plane_points, not in projections.
  int64_t run_skipped = 0;
  /// Plane points within a ray's depth bounds where no point can be inside
  /// (EmptySpace::DepthBounds' hit bounds), not visited: before the first plane
  /// whose near miss could scan into them (their near misses counted only
  /// when which are the first kept depends on it) and past the first plane
  /// beyond them. Not in plane_points.
  int64_t hit_skipped = 0;
  /// Wall milliseconds (added to, not reset): the sweep with its per-ray
  /// bisection, and the silhouette/rim refinement pass (the latency budget's
  /// recon "sweep" and "refine", docs/latency.md).
  double sweep_ms = 0, refine_ms = 0;
};

/// CPU plane sweep over the pixels of `tile` (a rectangle of the full view).
/// Returns a CV_32FC1 depth image of the tile's size: eye z (metres) of the first
/// plane whose point is inside the hull, or kNoDepth (+inf). The result equals
/// testing every plane of every pixel in order (the paper's sweep); it skips only
/// planes outside the hull box, where no point can be inside. threads >= 1 splits
/// rows across threads. refine_iterations > 0 (beyond the paper; docs/benchmarks.md) then
/// (1) bisects each pixel's depth between its last outside point (the previous
/// plane or the hull box entry) and the first inside plane, with point queries:
/// depth error shrinks by 2^-iterations of the plane spacing instead of depending
/// on the plane count; (2) at silhouettes and occluding rims (a neighbour nearer by
/// more than a plane, or a neighbour with hull where this pixel has none), where a
/// grazing ray's piece of hull can fall between two planes, rescans the ray near
/// the neighbour's depth at 1/8 of the spacing and bisects a hit. Tiles of a view
/// still assemble to exactly the whole-view result. 0 keeps the paper's result,
/// identical to the GL sweep. `stop` (util/interrupt.h) is polled per pixel: once
/// it is set the sweep ends within a pixel's work per thread and throws
/// Interrupted (a node stops mid-sweep on SIGINT).
cv::Mat PlaneSweepCpu(const VolumeQuery& query, const NovelView& view,
                      const std::vector<double>& plane_depths, const cv::Rect& tile,
                      SweepStats* stats = nullptr, int threads = 1, int refine_iterations = 0,
                      StopFlag stop = nullptr);

/// Where the CPU sweep visits the rays of a region of a view (PlaneSweepCpu):
/// per block of EmptySpace::kBoundsBlock x kBoundsBlock pixels (block (i, j)
/// from pixel (kBoundsBlock * j, kBoundsBlock * i) of the region), eye depths
/// in metres, CV_32FC1:
///   - [near, far]: outside them a block's rays hold no point that is inside
///     or a near miss (one camera alone vetoes it);
///   - [hit_near, hit_far]: outside them none is inside (near > far or
///     hit_near > hit_far: nowhere).
struct SweepBounds {
  cv::Mat near, far, hit_near, hit_far;
};

/// SweepBounds of `region` of `view` for the sweep over `plane_depths`: the
/// empty-space grid's (EmptySpace::DepthBounds) narrowed by pieces of the
/// view's own frustum, a block's rays between two planes (kSlabPlanes apart,
/// plane_sweep.cc): pieces one camera puts wholly on background
/// (VolumeQuery::CountWholeBackground) are cut from the hit bounds from the
/// front and the back, and (`near_misses`: for a sweep that looks for them,
/// refining) pieces two cameras do from the near bound; the cut depths
/// rounded outward to floats. False, leaving *out empty, when the grid gives
/// no bounds (an eye within reach of the hull box, a region too small for the
/// grid's cost). Throws Interrupted once `stop` is set (polled per row of
/// blocks). The rows of blocks are shared by `threads` workers (>= 1), the
/// bounds the same on any number.
bool SweepDepthBounds(const VolumeQuery& query, const NovelView& view, const cv::Rect& region,
                      const std::vector<double>& plane_depths, bool near_misses, SweepBounds* out,
                      StopFlag stop = nullptr, int threads = 1);

/// Depth refinement (beyond the paper; docs/benchmarks.md) of a finished sweep, for backends
/// that cannot refine themselves (the GL sweep): each finite depth in *depth (a
/// plane of `depths`, as the sweep returned it for `tile`) is bisected
/// `iterations` times between the previous plane (or the hull box entry) and
/// itself with point queries. Gives the same result as PlaneSweepCpu with
/// refine_iterations, up to float rounding. Throws std::invalid_argument if *depth
/// is not CV_32FC1 of the tile's size; Interrupted once `stop` is set (polled per pixel).
void RefineSweepDepth(const VolumeQuery& query, const NovelView& view, const std::vector<double>& depths,
                      const cv::Rect& tile, int iterations, cv::Mat* depth, int threads = 1,
                      StopFlag stop = nullptr);

/// Tile i of n of a view: n horizontal bands of (nearly) equal height, top first.
/// Throws std::invalid_argument unless 0 <= i < n <= height.
cv::Rect TileRect(int i, int n, int width, int height);

}  // namespace hullpipe
