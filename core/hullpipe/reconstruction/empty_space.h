// Empty-space skipping for the CPU plane sweep (beyond the paper, whose §3.3
// sweep queries every plane point; docs/benchmarks.md "A head-mounted display").
// A frameset's hull box is cut into a grid of cubes, and each cube is given
// the number of cameras (0, 1, or 2 for two or more) that each see all of it
// and put all of it on background (VolumeQuery::CountWholeBackground). No
// point of a cube one camera vetoes is inside; no point of a cube two cameras
// veto is a near miss either (a point exactly one camera vetoes, which the
// sweep's refinement rescans). So a sweep that answers such points from the
// grid returns exactly what it returns when it asks every camera: the grid
// only saves work. It is made once per frameset and shared by every view swept
// from it (both eyes of a head-mounted display, the visibility maps).
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/util/interrupt.h"

namespace hullpipe {

class VolumeQuery;

/// A grid over a query's hull box: how many cameras veto each whole cube.
class EmptySpace {
 public:
  /// The most cubes along the hull box's longest side.
  static constexpr int kMaxCellsPerAxis = 128;
  /// The camera tests (blocks x cameras, level by level) the grid may take:
  /// about 0.8 ms on one core for the Utrecht rig's distorted cameras. In the
  /// demo on two cores, four times as many cost recon more than the finer
  /// cubes saved its sweep (docs/benchmarks.md).
  static constexpr int64_t kMaxCameraTests = 8192;
  /// A level of fewer blocks is tested on the calling thread alone: handing
  /// its blocks to the threads costs more than their tests.
  static constexpr size_t kMinBlocksPerThreadedLevel = 1024;

  /// A grid that knows nothing (every cube 0).
  EmptySpace() = default;
  /// The grid of `query` (its hull box, maps and cameras): `cells_per_axis`
  /// cubes along the box's longest side (clamped to [1, kMaxCellsPerAxis]; 0
  /// makes a grid that knows nothing), cubes of one side. Found by halving
  /// blocks of cubes from the whole grid down, level by level: a block two
  /// cameras veto is marked whole; one that one camera vetoes is marked 1 and
  /// halved on to find parts a second camera vetoes; a level runs only while
  /// its blocks x cameras fit in kMaxCameraTests (the blocks of a level not run
  /// keep their parent's count); each level's blocks are handed to `threads`
  /// threads (>= 1; one for a level under kMinBlocksPerThreadedLevel blocks),
  /// the grid the same on any number. The query must outlive only this call.
  EmptySpace(const VolumeQuery& query, int cells_per_axis, int threads);

  /// True when every cube is 0 (the sweep then skips the lookups).
  bool knows_nothing() const { return vetoed_ == 0; }
  /// Grid coordinates (cube units, origin at the grid's min corner) of world
  /// point X (metres): cube (floor(g.x), floor(g.y), floor(g.z)).
  Eigen::Vector3d GridFromWorld(const Eigen::Vector3d& X_world) const { return (X_world - origin_) * inv_cell_; }
  /// A world direction or displacement (metres) in grid units (cubes).
  Eigen::Vector3d GridFromWorldDirection(const Eigen::Vector3d& d_world) const { return d_world * inv_cell_; }
  /// The cameras (0, 1, or 2 for two or more) that veto every point of the
  /// cube holding grid point g; 0 outside the grid and for non-finite g.
  /// Inline for the sweep's inner loop.
  int Vetoes(float gx, float gy, float gz) const {
    // The stored grid has a ring of 0 cubes around it: a point is clamped
    // into the ring (NaN to its first cube: std::max(0, NaN) is 0), then
    // truncated; no branch.
    const unsigned x = unsigned(std::min(top_[0], std::max(0.0f, gx + 1.0f)));
    const unsigned y = unsigned(std::min(top_[1], std::max(0.0f, gy + 1.0f)));
    const unsigned z = unsigned(std::min(top_[2], std::max(0.0f, gz + 1.0f)));
    return vetoes_[Stored(x, y, z)];
  }

  /// Pixels per side of DepthBounds' blocks.
  static constexpr int kBoundsBlock = 8;
  /// DepthBounds bounds a region only of at least this many pixels per cube
  /// two cameras do not veto (each such cube is projected).
  static constexpr int64_t kPixelsPerOpenCube = 4;
  /// For each block of kBoundsBlock x kBoundsBlock pixels of `region` (a
  /// rectangle of `view`'s pixels; block (i, j) holds the region's pixels
  /// from (kBoundsBlock * j, kBoundsBlock * i), the last ones cut by its edge):
  /// the eye depths [(*near)(i, j), (*far)(i, j)] outside of which the rays
  /// through its pixels' centres meet only cubes that two cameras veto (near >
  /// far: nowhere else). Both CV_32FC1, ceil(height / kBoundsBlock) x
  /// ceil(width / kBoundsBlock). Found by projecting every other cube's corners
  /// into the view (a block's bounds are the extremes of the cubes whose image,
  /// grown by a pixel, holds one of its pixels' centres, widened by 0.1 mm;
  /// cubes wholly behind the eye hold no sample and are left out). False,
  /// leaving both empty, when the grid knows nothing, the region has fewer
  /// than kPixelsPerOpenCube pixels per cube two cameras do not veto, or such
  /// a cube reaches from behind the eye to within a millimetre in front of it
  /// (then no pixel is bounded). A ray's samples outside its bounds are neither inside nor
  /// near misses, so the sweep need not visit them. `stop` is polled per cube:
  /// once set, throws Interrupted.
  /// `hit_near`, `hit_far` (if given; left empty when false is returned): the
  /// same for the cubes no camera vetoes, made the same way: the eye depths
  /// outside of which a block's rays meet only cubes some camera vetoes whole,
  /// where no point is inside the hull. A ray's depth (its first inside
  /// point, planes, near-miss scans and silhouette pass alike) lies within
  /// them; near > far: the block's rays meet the hull nowhere.
  bool DepthBounds(const NovelView& view, const cv::Rect& region, cv::Mat* near, cv::Mat* far,
                   StopFlag stop = nullptr, cv::Mat* hit_near = nullptr, cv::Mat* hit_far = nullptr) const;

  /// Cubes along x, y, z (0 when the grid skips nothing).
  const Eigen::Vector3i& dims() const { return dims_; }
  /// Side of a cube, metres.
  double cell() const { return inv_cell_ > 0 ? 1.0 / inv_cell_ : 0.0; }
  /// Cubes one camera vetoes (exactly), two or more veto, and the blocks
  /// tested while making the grid.
  int64_t vetoed_once() const { return vetoed_ - vetoed_twice_; }
  int64_t vetoed_twice() const { return vetoed_twice_; }
  int64_t tests() const { return tests_; }
  /// Wall milliseconds the grid took to make.
  double build_ms() const { return build_ms_; }

 private:
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  double inv_cell_ = 0;
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  // The stored grid: dims_ + 2 cubes along each axis (a ring of 0 cubes
  // around the grid), and the largest padded coordinate that truncates into it.
  unsigned padded_[3] = {1, 1, 1};
  // Index into vetoes_ of stored cube (x, y, z): the grid's cube (i, j, k) is
  // stored at (i + 1, j + 1, k + 1).
  size_t Stored(size_t x, size_t y, size_t z) const { return (z * padded_[1] + y) * padded_[0] + x; }
  float top_[3] = {0.5f, 0.5f, 0.5f};
  std::vector<uint8_t> vetoes_ = {0};
  int64_t vetoed_ = 0, vetoed_twice_ = 0, tests_ = 0;
  double build_ms_ = 0;
};

}  // namespace hullpipe
