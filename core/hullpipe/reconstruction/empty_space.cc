#include "hullpipe/reconstruction/empty_space.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>

#include <opencv2/core.hpp>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/reconstruction/volume_query.h"
#include "hullpipe/util/interrupt.h"
#include "hullpipe/util/parallel.h"

namespace hullpipe {
namespace {

// A block of cubes [lo, hi) in grid indices.
struct Block {
  Eigen::Vector3i lo, hi;
  bool single() const { return ((hi - lo).array() <= 1).all(); }
};

// The world box of a block, grown by 0.1 mm: the sweep places a sample in a
// cube by float grid coordinates and projects it in floats, each within about
// a micrometre of the exact point, so the sample lies in the grown cube.
constexpr double kGrowth = 1e-4;

}  // namespace

EmptySpace::EmptySpace(const VolumeQuery& query, int cells_per_axis, int threads) {
  const double t0 = MonotonicSeconds();
  const Aabb& box = query.hull_box();
  if (box.empty() || cells_per_axis <= 0) return;
  const int n = std::clamp(cells_per_axis, 1, kMaxCellsPerAxis);
  const Eigen::Vector3d size = box.max - box.min;
  const double side = size.maxCoeff() / n;
  if (!(side > 0) || !std::isfinite(side)) return;
  for (int a = 0; a < 3; ++a) {
    dims_[a] = std::clamp(int(std::ceil(size[a] / side - 1e-9)), 1, n);
    padded_[a] = unsigned(dims_[a] + 2);
    top_[a] = float(padded_[a]) - 0.5f;
  }
  origin_ = box.min;
  inv_cell_ = 1.0 / side;
  vetoes_.assign(size_t(padded_[0]) * padded_[1] * padded_[2], 0);

  auto world = [&](const Block& b) {
    Aabb w;
    w.min = origin_ + b.lo.cast<double>() * side - Eigen::Vector3d::Constant(kGrowth);
    w.max = origin_ + b.hi.cast<double>() * side + Eigen::Vector3d::Constant(kGrowth);
    return w;
  };
  auto mark = [&](const Block& b, uint8_t count) {
    for (int z = b.lo.z(); z < b.hi.z(); ++z)
      for (int y = b.lo.y(); y < b.hi.y(); ++y)
        std::fill_n(vetoes_.begin() + long(Stored(size_t(b.lo.x() + 1), size_t(y + 1), size_t(z + 1))),
                    b.hi.x() - b.lo.x(), count);
  };
  // Halves a block along its longest index extent.
  auto split = [](const Block& b, Block* lo, Block* hi) {
    const Eigen::Vector3i ext = b.hi - b.lo;
    int a = 0;
    for (int k = 1; k < 3; ++k)
      if (ext[k] > ext[a]) a = k;
    *lo = *hi = b;
    lo->hi[a] = hi->lo[a] = b.lo[a] + ext[a] / 2;
  };
  // Tests a block and marks it with its count; true when that settles it (two
  // cameras, which every part of it has too, or a single cube). A part of a
  // block has at least the block's count: a camera that sees all of the block
  // sees all of the part, on the same background.
  std::atomic<int64_t> tests{0};
  auto test = [&](const Block& b, size_t* hint) {
    tests.fetch_add(1, std::memory_order_relaxed);
    const int count = query.CountWholeBackground(world(b), 2, hint);
    if (count > 0) mark(b, uint8_t(count));
    return count >= 2 || b.single();
  };
  // Level by level, coarse first: a level's blocks are tested on the threads,
  // and the blocks not settled are halved into the next level, while the
  // camera tests a level may take (blocks x cameras) fit in the budget. A
  // block of a level not reached keeps its parent's count, a lower bound, so
  // the grid stays sound; the budget keeps a many-camera rig, whose tight hull
  // box gains little from fine cubes, from paying for them. Which levels run
  // depends on counts only, not on the threads: the grid is the same on any.
  std::vector<Block> level{Block{Eigen::Vector3i::Zero(), dims_}};
  int64_t budget = kMaxCameraTests;
  const int64_t cameras = int64_t(query.size());
  for (bool first = true; !level.empty(); first = false) {
    const int64_t cost = int64_t(level.size()) * cameras;
    if (!first && cost > budget) break;
    budget -= cost;
    std::vector<uint8_t> settled(level.size(), 0);
    // A coarse level's few blocks are tested on this thread: handing them to
    // the threads costs more than their tests (most of the ~14 levels are small).
    const int level_threads = level.size() >= kMinBlocksPerThreadedLevel ? std::max(1, threads) : 1;
    ForEachRowDynamic(int(level.size()), level_threads, [&](int i, int) {
      size_t hint = 0;
      settled[size_t(i)] = test(level[size_t(i)], &hint) ? 1 : 0;
    });
    std::vector<Block> next;
    for (size_t i = 0; i < level.size(); ++i) {
      if (settled[i]) continue;
      Block lo, hi;
      split(level[i], &lo, &hi);
      next.push_back(lo);
      next.push_back(hi);
    }
    level.swap(next);
  }
  const int64_t tested = tests.load();
  vetoed_twice_ = int64_t(std::count(vetoes_.begin(), vetoes_.end(), uint8_t(2)));
  vetoed_ = vetoed_twice_ + int64_t(std::count(vetoes_.begin(), vetoes_.end(), uint8_t(1)));
  if (vetoed_ == 0) *this = EmptySpace();
  tests_ = tested;
  build_ms_ = (MonotonicSeconds() - t0) * 1e3;
}

bool EmptySpace::DepthBounds(const NovelView& view, const cv::Rect& region, cv::Mat* near, cv::Mat* far,
                             StopFlag stop, cv::Mat* hit_near, cv::Mat* hit_far) const {
  for (cv::Mat* m : {near, far, hit_near, hit_far})
    if (m) *m = cv::Mat();
  if (knows_nothing() || region.area() <= 0) return false;
  // Each cube two cameras do not veto is projected: for a view of few pixels
  // (the visibility maps' 80x60) that costs more than its bounds save.
  const int64_t open = int64_t(dims_.prod()) - vetoed_twice_;
  if (int64_t(region.area()) < kPixelsPerOpenCube * open) return false;
  constexpr int B = kBoundsBlock;
  const int block_cols = (region.width + B - 1) / B, block_rows = (region.height + B - 1) / B;
  const Rigid3d eye_from_world = view.world_from_eye.Inverse();
  const double side = cell();
  // Corner (i, j, k) of the grid in the eye's frame: p0 + i ex + j ey + k ez.
  const Eigen::Vector3d p0 = eye_from_world * origin_;
  const Eigen::Matrix3d R = eye_from_world.rotation * side;
  const Eigen::Vector3d ex = R.col(0), ey = R.col(1), ez = R.col(2);
  cv::Mat lo(block_rows, block_cols, CV_32FC1, cv::Scalar(std::numeric_limits<float>::infinity()));
  cv::Mat hi(block_rows, block_cols, CV_32FC1, cv::Scalar(-std::numeric_limits<float>::infinity()));
  cv::Mat lo0 = lo.clone(), hi0 = hi.clone();  // the cubes no camera vetoes
  constexpr double kZMin = 1e-3;
  for (int k = 0; k < dims_.z(); ++k)
    for (int j = 0; j < dims_.y(); ++j)
      for (int i = 0; i < dims_.x(); ++i) {
        const uint8_t vetoes = vetoes_[Stored(size_t(i + 1), size_t(j + 1), size_t(k + 1))];
        if (vetoes >= 2) continue;
        ThrowIfStopped(stop, "the plane sweep's depth bounds");
        const Eigen::Vector3d c = p0 + double(i) * ex + double(j) * ey + double(k) * ez;
        std::array<Eigen::Vector3d, 8> p;
        double z0 = 1e300, z1 = -1e300, u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
        for (int q = 0; q < 8; ++q) {
          p[size_t(q)] = c + (q & 1 ? ex : Eigen::Vector3d::Zero()) + (q & 2 ? ey : Eigen::Vector3d::Zero()) +
                         (q & 4 ? ez : Eigen::Vector3d::Zero());
          z0 = std::min(z0, p[size_t(q)].z()), z1 = std::max(z1, p[size_t(q)].z());
        }
        // Wholly behind the eye (an eye inside the hull box): no sample, all at
        // positive depth, lies in it. Reaching the eye's plane: no bounds.
        if (!(z1 > 0)) continue;
        if (!(z0 > kZMin)) return false;
        for (const Eigen::Vector3d& x : p) {
          const double u = view.fx * x.x() / x.z() + view.cx, v = view.fy * x.y() / x.z() + view.cy;
          u0 = std::min(u0, u), u1 = std::max(u1, u);
          v0 = std::min(v0, v), v1 = std::max(v1, v);
        }
        // Pixels whose centre (col + 0.5, row + 0.5) is within the image of
        // the cube grown by a pixel, in region coordinates, then their blocks.
        const int px0 = std::max(0, int(std::ceil(std::max(u0 - 1.5, -1e9))) - region.x);
        const int px1 = std::min(region.width - 1, int(std::floor(std::min(u1 + 0.5, 1e9))) - region.x);
        const int py0 = std::max(0, int(std::ceil(std::max(v0 - 1.5, -1e9))) - region.y);
        const int py1 = std::min(region.height - 1, int(std::floor(std::min(v1 + 0.5, 1e9))) - region.y);
        if (px0 > px1 || py0 > py1) continue;
        const int c0 = px0 / B, c1 = px1 / B, r0 = py0 / B, r1 = py1 / B;
        const float zn = float(z0 - kGrowth), zf = float(z1 + kGrowth);
        for (int r = r0; r <= r1; ++r) {
          float* l = lo.ptr<float>(r);
          float* h = hi.ptr<float>(r);
          for (int col = c0; col <= c1; ++col) {
            l[col] = std::min(l[col], zn);
            h[col] = std::max(h[col], zf);
          }
          if (vetoes != 0) continue;
          float* l0 = lo0.ptr<float>(r);
          float* h0 = hi0.ptr<float>(r);
          for (int col = c0; col <= c1; ++col) {
            l0[col] = std::min(l0[col], zn);
            h0[col] = std::max(h0[col], zf);
          }
        }
      }
  *near = lo;
  *far = hi;
  if (hit_near) *hit_near = lo0;
  if (hit_far) *hit_far = hi0;
  return true;
}

}  // namespace hullpipe
