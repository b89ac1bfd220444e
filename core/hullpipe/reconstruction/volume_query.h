// Volume querying (paper §3.2): a 3D point is inside the visual hull iff it
// projects onto an object pixel in every one of the n cameras' object-pixel maps.
// This is the CPU reference that every other path (GL sweep, GL triangle query)
// is tested against.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/camera.h"

namespace hullpipe {

/// One camera's calibration with its object-pixel map for one frame
/// (CV_8UC1, camera.width x camera.height, non-zero = object).
struct CameraMap {
  Camera camera;
  cv::Mat map;
  /// The map's object pixels' bounding rectangle if already known (decoding its
  /// runs gives it: segmentation/object_pixel_map.h, DecodedMap); nullopt:
  /// VolumeQuery scans the map for it. It must be the exact rectangle.
  std::optional<cv::Rect> object_rect;
};

namespace detail {
/// A camera's projection reduced to floats for hot loops (see VolumeQuery::VoteFast).
struct FastCamera {
  float r[9], t[3];
  float fx, fy, cx, cy, skew;
  float k1, k2, p1, p2, k3;
  float r2max;
  bool distorted;
  int width, height;
  float width_f, height_f;  // width, height as floats (VoteFast's bounds)
  const uint8_t* data;
  size_t step;
};
/// The pixel (u, v) of a point at normalised image coordinates (xn, yn),
/// r2 = xn^2 + yn^2, through camera c's lens (Brown-Conrady k1, k2, p1, p2,
/// k3 as Camera::Distort) and intrinsics, in floats: VoteFast's arithmetic,
/// which every float test of the sweep shares.
inline void FastPixel(const FastCamera& c, float xn, float yn, float r2, float* u, float* v) {
  if (c.distorted) {
    const float radial = 1.0f + r2 * (c.k1 + r2 * (c.k2 + r2 * c.k3));
    const float xy = xn * yn;
    const float xd = xn * radial + 2.0f * c.p1 * xy + c.p2 * (r2 + 2.0f * xn * xn);
    const float yd = yn * radial + c.p1 * (r2 + 2.0f * yn * yn) + 2.0f * c.p2 * xy;
    xn = xd;
    yn = yd;
  }
  *u = c.fx * xn + c.skew * yn + c.cx;
  *v = c.fy * yn + c.cy;
}
class CellProver;  // volume_query.cc: the hull box search's rule for empty cells
struct LazyEmptySpace;  // volume_query.cc: the grid, made on first use
}  // namespace detail

/// What a camera says of a point it cannot see: behind it (z <= 0), outside its
/// image, or beyond its distortion model's valid radius.
enum class OutOfView {
  /// The camera vetoes the point: it is outside the hull (the paper's rule; the
  /// hull is clipped to the intersection of all views).
  kOutside,
  /// The camera does not vote: the hull is not clipped where a camera cannot see.
  /// The point is inside iff every camera that sees it puts it on object pixels and
  /// at least min_seen cameras see it (so a region one camera alone sees is not a
  /// silhouette cone running to the workspace's edge).
  kUnknown,
};

/// One camera's verdict on a point (VolumeQuery::Vote).
enum class Vote : uint8_t { kBackground = 0, kObject = 1, kUnseen = 2 };

/// How far a lens bends a small piece of the world's image, as the hull box
/// search, the empty-space grid and the sweep's near-miss scans bound it: the
/// distorted image of a segment or cell (in front of the camera and within its
/// lens model's valid radius) whose distorted corners' pixel box has larger
/// side span_px <= kMaxBulgeSpanPx lies within that box grown by
/// LensBulgePx(span_px) pixels. A segment whose normalised image moves by
/// |dx| bends from its chord by at most |D''| |dx|^2 f / 8 px (D the
/// distortion, f the focal length): for the Utrecht rig's lenses (k1 = -0.37,
/// f = 491 px) at most span^2 / 4500 over its images (100,000 segments of 2 to
/// 32 px sampled), a tenth of this margin.
inline constexpr double kMaxBulgeSpanPx = 32;
inline double LensBulgePx(double span_px) { return 0.5 + span_px * span_px / 400; }

/// Settings of a volume query.
struct VolumeQueryOptions {
  OutOfView out_of_view = OutOfView::kUnknown;  ///< Default: do not clip by views.
  /// With kUnknown: the fewest cameras that must see a point for it to be inside
  /// (clamped to n; >= 1).
  int min_seen = 2;
  /// Threads for the hull box search (its six faces at once; 1..256). The box
  /// is the same with any number.
  int threads = 1;
  /// Cubes along the hull box's longest side of the grid the CPU sweep uses to
  /// skip empty space (EmptySpace; [0, EmptySpace::kMaxCellsPerAxis], 0: no
  /// skipping). The sweep's result is the same with any value.
  int empty_space_cells = 32;
  /// Whether the CPU sweep's refinement skips the scan of a near miss (a point
  /// exactly one camera vetoes) when that camera's object-pixel map is
  /// background under the whole bracket's projection (SegmentOnBackground; a
  /// distorted camera's curved projection bounded by LensBulgePx): such a scan
  /// finds nothing. The sweep's result is the same either way
  /// (docs/benchmarks.md, "Near-miss scans a camera vetoes whole" and
  /// "Near-miss scans skipped through real lenses").
  bool prune_near_misses = true;
  /// Whether the CPU sweep with refinement, after a camera puts a ray's point
  /// on a background pixel, tries the next planes' points as one segment (4 to
  /// 32 points, with the planes either side): where that camera holds the
  /// whole segment on background (SegmentOnBackground) they are all outside,
  /// and any near miss among them has nothing to scan, so they are skipped
  /// without a projection. Their near misses are counted only where the count
  /// decides which near misses are scanned. The sweep's result is the same
  /// either way (docs/benchmarks.md, "Runs of background skipped in the CPU
  /// sweep").
  bool skip_background_runs = true;
  /// Throws std::invalid_argument naming the bad field.
  void Check() const;
};

/// The visual hull of one frameset, queryable point by point.
/// A point outside the workspace box is outside. A camera that cannot see a point
/// votes as VolumeQueryOptions::out_of_view says (default: it does not vote).
class EmptySpace;

class VolumeQuery {
 public:
  /// views: the n cameras and their maps (n >= 1). workspace: world box (metres)
  /// outside which nothing is hull (DefaultWorkspace if unsure). Computes the hull's
  /// bounding box (HullBoundingBox; with kUnknown, see hull_box()). Throws
  /// std::invalid_argument if a map is not CV_8UC1 of its camera's size, n == 0, or
  /// the options fail Check(). The maps are shared, not copied.
  VolumeQuery(std::vector<CameraMap> views, const Aabb& workspace, const VolumeQueryOptions& options = {});

  const VolumeQueryOptions& options() const { return options_; }
  /// The number of cameras that must see a point for it to be inside: n with
  /// kOutside (all), min(min_seen, n) with kUnknown.
  int required_seen() const { return required_seen_; }

  /// Number of cameras n.
  size_t size() const { return views_.size(); }
  const std::vector<CameraMap>& views() const { return views_; }
  const Aabb& workspace() const { return workspace_; }
  /// Conservative box of the hull (every inside point is in it), world metres.
  /// Started from the silhouette pyramids -- kOutside: the intersection of all
  /// cameras' pyramids (empty if some map is empty); kUnknown: the union, over
  /// the required_seen()-subsets of cameras grown by those that see their whole
  /// box, of those boxes -- then tightened by a best-first octree search per face
  /// that drops cells a camera proves empty (volume_query.cc, TightenHullBox):
  /// within about two leaves (1/64 of the start box, 5 mm to 2 cm) of the hull's
  /// own box. Empty when the hull is. Paper §3.2; docs/rigs.md.
  const Aabb& hull_box() const { return hull_box_; }

  /// True iff X (world metres) lies in the workspace and the cameras' votes make
  /// it inside: kOutside, object in all n (§3.2, "inside iff count == n");
  /// kUnknown, no camera says background and at least required_seen() see it.
  bool Inside(const Eigen::Vector3d& X_world) const;

  /// True if no point of `box` (world metres) can be inside the hull: it misses
  /// hull_box() or the workspace, or one camera that sees all of it has no
  /// object pixel under its projection (the same rule that tightens hull_box():
  /// volume_query.cc, TightenHullBox), or (kOutside) a camera sees none of it,
  /// or (kUnknown) fewer than required_seen() cameras can see any of it.
  /// Conservative: false does not mean a hull point is there. `hint` (optional,
  /// in/out): the camera tried first, set to the one that proved the box empty
  /// (neighbouring boxes tend to share it). Thread-safe. Paper §4.1 (the
  /// bounding-box test), applied to a hierarchy's boxes.
  bool ProvesEmpty(const Aabb& box, size_t* hint = nullptr) const;

  /// How many cameras, counting up to `need`, put every point of `box` (world
  /// metres) on background in the sweep's float arithmetic (VoteFast) as well
  /// as in doubles: each sees all of the box, its projection's bounding
  /// rectangle grown by a pixel within the image, every corner at least a
  /// millimetre in front and within the lens model's valid radius, and no
  /// object pixel under that rectangle. Each such camera vetoes every point of
  /// the box under either OutOfView policy. Conservative: a camera may veto the
  /// whole box and not be counted. 0 for an empty box or need <= 0. `hint`
  /// (optional, in/out): the camera tried first, set to the first one counted.
  /// Thread-safe. Used to skip empty space in the sweep (EmptySpace).
  int CountWholeBackground(const Aabb& box, int need, size_t* hint = nullptr) const;

  /// Four rays from one point in every camera's frame (views() order): per
  /// camera the origin, then the four directions, metres. Filled by BundleOf.
  struct RayBundle {
    std::vector<std::array<Eigen::Vector3d, 5>> in_camera;
  };
  /// The rays origin_world + t * dirs_world[r] (world metres) as a RayBundle,
  /// into *out (its storage reused).
  void BundleOf(const Eigen::Vector3d& origin_world, const std::array<Eigen::Vector3d, 4>& dirs_world,
                RayBundle* out) const;
  /// CountWholeBackground of the cell whose 8 vertices are the bundle's rays
  /// at t0 and at t1: a piece of a view's frustum between two eye depths when
  /// the directions are a block of pixels' corner rays scaled to eye z = 1
  /// (NovelView::EyeRay, rotated to the world), which makes the cell convex.
  /// The box's proof from the vertices' projections (perspective keeps
  /// convexity); other cells get no such guarantee. 0 for non-finite depths,
  /// a bundle of another query's cameras, or need <= 0. Thread-safe. The
  /// sweep's bounds test thousands of pieces a view (SweepDepthBounds).
  int CountWholeBackground(const RayBundle& rays, double t0, double t1, int need, size_t* hint = nullptr) const;

  /// This frameset's grid of cubes where the CPU sweep may skip every point
  /// (EmptySpace, options().empty_space_cells along the longest side), made on
  /// the first call with `threads` threads (>= 1) and shared by later calls and
  /// by copies of this query. Thread-safe.
  const EmptySpace& empty_space(int threads = 1) const;

  /// True if camera i's object-pixel map has no object pixel in the pixels
  /// [x0, x1) x [y0, y1) (clipped to the image; an empty rectangle has none),
  /// in four reads of the summed-area table the hull box search made of the
  /// map within its object rectangle. The sweep's near-miss scans ask it
  /// whether the vetoing camera vetoes a whole bracket (plane_sweep.cc).
  /// Thread-safe.
  bool NoObjectPixelIn(size_t i, int x0, int y0, int x1, int y1) const;

  /// True if camera i puts every point of the segment from a_cam to b_cam
  /// (its own frame, metres; the points the sweep computes as A + t B in
  /// floats) on a background pixel, as VoteFast votes: every pixel of a
  /// rectangle holding the segment's image, grown by a pixel for float
  /// rounding, lies in the image and is background (NoObjectPixelIn). For a
  /// pinhole camera the image is the segment between its ends' pixels; a
  /// distorted camera's bends from that chord by at most LensBulgePx, and
  /// both ends must be a millimetre in front and within the lens model's
  /// valid radius by a relative 1e-4 (as the hull box search's strict cells).
  /// Conservative: false does not mean an object pixel is there. The sweep's
  /// near-miss scans skip a bracket the vetoing camera holds on background
  /// (VolumeQueryOptions::prune_near_misses). Thread-safe.
  bool SegmentOnBackground(size_t i, const Eigen::Vector3f& a_cam, const Eigen::Vector3f& b_cam) const;

  /// Camera i's verdict on X (world metres), in double precision.
  Vote VoteOf(size_t i, const Eigen::Vector3d& X_world) const;

  /// Number of cameras in which X projects onto an object pixel (0..n); the
  /// stencil count of the paper's sweep.
  int Count(const Eigen::Vector3d& X_world) const;

  /// A query over the cameras whose indices are listed (for leave-one-out tests).
  VolumeQuery Subset(const std::vector<int>& indices) const;

  /// Float camera parameters for hot loops, in views() order.
  const std::vector<detail::FastCamera>& fast() const { return fast_; }

  /// Camera i's object pixels' bounding rectangle (empty when its map has
  /// none): every pixel outside it is background (the GL path uploads and
  /// reads only this part of each map).
  const cv::Rect& object_rect(size_t i) const { return rects_.at(i); }

  /// Camera `c`'s verdict on camera-frame point (x, y, z), in floats. Inline for
  /// the hot loops (sweep, reprojection).
  static Vote VoteFast(const detail::FastCamera& c, float x, float y, float z) {
    if (!(z > 1e-6f)) return Vote::kUnseen;
    const float iz = 1.0f / z;
    const float xn = x * iz, yn = y * iz;
    const float r2 = xn * xn + yn * yn;
    if (!(r2 <= c.r2max)) return Vote::kUnseen;
    float u = 0, v = 0;
    detail::FastPixel(c, xn, yn, r2, &u, &v);
    if (!(u >= 0.0f && v >= 0.0f && u < c.width_f && v < c.height_f)) return Vote::kUnseen;
    // In [0, width) x [0, height): int truncation is the pixel.
    return c.data[size_t(int(v)) * c.step + size_t(int(u))] != 0 ? Vote::kObject : Vote::kBackground;
  }

  /// True if this one vote already puts the point outside: background, or unseen
  /// under kOutside. Hot loops stop at the first such camera.
  bool Vetoes(Vote v) const {
    return v == Vote::kBackground || (v == Vote::kUnseen && options_.out_of_view == OutOfView::kOutside);
  }

  /// Whether votes make a point inside: `object` cameras voted object, `unseen`
  /// could not see it, none voted background (the caller stops at the first
  /// background vote).
  bool Accepts(int object, int unseen) const {
    return (unseen == 0 || options_.out_of_view == OutOfView::kUnknown) && object >= required_seen_;
  }

 private:
  std::vector<CameraMap> views_;
  Aabb workspace_;
  VolumeQueryOptions options_;
  int required_seen_ = 1;
  Aabb hull_box_;
  std::vector<detail::FastCamera> fast_;
  std::vector<cv::Rect> rects_;
  std::shared_ptr<const detail::CellProver> prover_;
  std::shared_ptr<detail::LazyEmptySpace> empty_space_;
};

}  // namespace hullpipe
