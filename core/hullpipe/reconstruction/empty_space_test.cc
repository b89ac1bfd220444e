// Empty-space skipping (empty_space.h): every cube the grid marks is vetoed by
// as many cameras as it says, at every point, in doubles and in the sweep's
// floats; every pixel's depth bounds hold only cubes two cameras veto outside
// them; and a sweep that skips returns bit for bit what one that asks every
// camera returns (refined or not, tiled, eyes inside the hull box, skewed and
// distorted cameras). Each with a control that the grid skips a lot, so that
// equality is not vacuous.
#include "hullpipe/reconstruction/empty_space.h"

#include <random>

#include <gtest/gtest.h>

#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/stereo_views.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

using test::kSphereCentre;
using test::kSphereRadius;

// A figure like the bench's (a body, a head, arms, legs) seen by n ring cameras
// with exact maps: a hull with thin parts, ghosts and near misses.
std::vector<CameraMap> FigureViews(int n, const Distortion& d = {}, double skew = 0) {
  const Eigen::Vector3d c = kSphereCentre;
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Sphere(c + Eigen::Vector3d(0, 0, -0.55), 0.11));
  scene.shapes.push_back(Shape::Capsule(c + Eigen::Vector3d(0, 0, -0.35), c + Eigen::Vector3d(0, 0, 0.1), 0.16));
  scene.shapes.push_back(
      Shape::Capsule(c + Eigen::Vector3d(0.2, 0, -0.3), c + Eigen::Vector3d(0.45, 0.25, 0.0), 0.045));
  scene.shapes.push_back(Shape::Capsule(c + Eigen::Vector3d(0.1, 0, 0.15), c + Eigen::Vector3d(0.12, 0.45, 0.6), 0.07));
  return test::ExactViews(test::WithSkew(RingCameras(n, 3.0, 1.8, c, 322, 243, 1.0, d), skew), scene);
}

// A view of the figure from 7 m, outside every hull box here (with four
// cameras the box reaches past the ring): the sweep gets depth bounds.
NovelView FarView(int w, int h, double hfov = 0.5) {
  return NovelView::FromFov(w, h, hfov,
                            LookAt(kSphereCentre + Eigen::Vector3d(6.0, 3.6, -1.5), kSphereCentre,
                                   Eigen::Vector3d(0, 0, -1)));
}

VolumeQuery Query(std::vector<CameraMap> views, int cells) {
  VolumeQueryOptions o;
  o.empty_space_cells = cells;
  return VolumeQuery(std::move(views), test::BigBox(), o);
}

// Camera c's float vote on world point X, as the sweep's VoteFast computes it.
Vote FloatVote(const VolumeQuery& q, size_t c, const Eigen::Vector3d& X) {
  const Eigen::Vector3f p = (q.views()[c].camera.cam_from_world * X).cast<float>();
  return VolumeQuery::VoteFast(q.fast()[c], p.x(), p.y(), p.z());
}

// Every cube's count, checked at random points of the cube (and on its faces
// and corners): at least that many cameras vote background there, in doubles
// and in floats. Returns the cubes vetoed twice.
int64_t CheckCubes(const VolumeQuery& q, const EmptySpace& grid, int points_per_cube) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0, 1);
  const Eigen::Vector3i n = grid.dims();
  int64_t twice = 0;
  const Eigen::Vector3d origin = q.hull_box().min;
  for (int k = 0; k < n.z(); ++k)
    for (int j = 0; j < n.y(); ++j)
      for (int i = 0; i < n.x(); ++i) {
        const int count = grid.Vetoes(float(i + 0.5), float(j + 0.5), float(k + 0.5));
        if (count == 0) continue;
        twice += count == 2;
        for (int s = 0; s < points_per_cube; ++s) {
          // Corners first, then random points.
          const Eigen::Vector3d f = s < 8 ? Eigen::Vector3d(s & 1, (s >> 1) & 1, (s >> 2) & 1)
                                          : Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
          const Eigen::Vector3d X = origin + (Eigen::Vector3d(i, j, k) + f) * grid.cell();
          int background = 0, background_f = 0;
          for (size_t c = 0; c < q.size(); ++c) {
            background += q.VoteOf(c, X) == Vote::kBackground;
            background_f += FloatVote(q, c, X) == Vote::kBackground;
          }
          if (background < count || background_f < count) {
            ADD_FAILURE() << "cube " << i << "," << j << "," << k << " marked " << count << ": " << background
                          << " cameras (" << background_f << " in floats) say background at " << X.transpose();
            return -1;
          }
        }
      }
  return twice;
}

TEST(EmptySpace, EveryMarkedCubeIsVetoedByAsManyCamerasEverywhere) {
  for (const int n : {4, 8}) {
    const VolumeQuery q = Query(FigureViews(n), 32);
    const EmptySpace& grid = q.empty_space(2);
    ASSERT_FALSE(grid.knows_nothing());
    const int64_t twice = CheckCubes(q, grid, 24);
    // Control: most of the hull box is empty space two cameras prove.
    EXPECT_GT(double(twice) / double(grid.dims().prod()), 0.5) << n << " cameras";
    EXPECT_EQ(twice, grid.vetoed_twice());
  }
  // Distorted and skewed cameras: the lens bound's rectangles.
  const Distortion d{-0.25, 0.08, 0.001, -0.001, -0.01};
  const VolumeQuery q = Query(FigureViews(6, d, 0.02), 32);
  EXPECT_GT(CheckCubes(q, q.empty_space(1), 24), 0);
}

TEST(EmptySpace, TheSameGridOnOneThreadOrSix) {
  const VolumeQuery a = Query(FigureViews(4), 32), b = Query(FigureViews(4), 32);
  const EmptySpace &ga = a.empty_space(1), &gb = b.empty_space(6);
  ASSERT_EQ(ga.dims(), gb.dims());
  for (int k = 0; k < ga.dims().z(); ++k)
    for (int j = 0; j < ga.dims().y(); ++j)
      for (int i = 0; i < ga.dims().x(); ++i)
        ASSERT_EQ(ga.Vetoes(i + 0.5f, j + 0.5f, k + 0.5f), gb.Vetoes(i + 0.5f, j + 0.5f, k + 0.5f));
  EXPECT_EQ(ga.vetoed_once(), gb.vetoed_once());
  EXPECT_EQ(ga.vetoed_twice(), gb.vetoed_twice());
}

TEST(EmptySpace, OutsideTheGridAndNonFiniteCountNothing) {
  const VolumeQuery q = Query(FigureViews(4), 32);
  const EmptySpace& grid = q.empty_space(1);
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  for (const float v : {-1.5f, -1e30f, 1e30f, nan, inf, -inf, float(grid.dims().x()) + 0.5f})
    EXPECT_EQ(grid.Vetoes(v, 1.5f, 1.5f), 0) << v;
  // A grid of 0 cubes along the side, or a default one, knows nothing.
  EXPECT_TRUE(Query(FigureViews(4), 0).empty_space(1).knows_nothing());
  EXPECT_EQ(EmptySpace().Vetoes(0.5f, 0.5f, 0.5f), 0);
  VolumeQueryOptions bad;
  bad.empty_space_cells = EmptySpace::kMaxCellsPerAxis + 1;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
  bad.empty_space_cells = -1;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
}

// Along pixel rays of a view, every sample in the hull box outside the pixel's
// depth bounds is vetoed by two cameras; the bounds leave most samples out.
TEST(EmptySpace, ARaysSamplesOutsideItsDepthBoundsAreVetoedTwice) {
  const VolumeQuery q = Query(FigureViews(4), 32);
  const EmptySpace& grid = q.empty_space(1);
  const NovelView view = FarView(240, 180);
  ASSERT_FALSE(q.hull_box().Contains(view.world_from_eye.translation));
  const cv::Rect region(9, 6, 210, 150);
  cv::Mat near, far, hit_near, hit_far;
  ASSERT_TRUE(grid.DepthBounds(view, region, &near, &far, nullptr, &hit_near, &hit_far));
  constexpr int B = EmptySpace::kBoundsBlock;
  ASSERT_EQ(near.size(), cv::Size((region.width + B - 1) / B, (region.height + B - 1) / B));
  ASSERT_EQ(hit_near.size(), near.size());
  int64_t outside = 0, all = 0, outside_hit = 0;
  for (int r = 0; r < region.height; r += 7)
    for (int c = 0; c < region.width; c += 7) {
      const float lo = near.at<float>(r / B, c / B), hi = far.at<float>(r / B, c / B);
      const float lo0 = hit_near.at<float>(r / B, c / B), hi0 = hit_far.at<float>(r / B, c / B);
      // The cubes no camera vetoes are among those two do not.
      if (lo0 <= hi0) {
        ASSERT_TRUE(lo <= lo0 && hi0 <= hi) << "block " << c / B << "," << r / B;
      }
      const Eigen::Vector3d O = view.world_from_eye.translation;
      const Eigen::Vector3d D =
          view.world_from_eye.rotation * view.EyeRay(region.x + c + 0.5, region.y + r + 0.5);
      double s0 = 0.05, s1 = 50;
      if (!q.hull_box().ClipRay(O, D, &s0, &s1)) continue;
      for (double s = s0; s <= s1; s += 0.004) {
        ++all;
        if (!(s >= lo0 && s <= hi0)) {
          ++outside_hit;
          bool vetoed = false;
          for (size_t k = 0; k < q.size() && !vetoed; ++k) vetoed = q.VoteOf(k, O + s * D) == Vote::kBackground;
          ASSERT_TRUE(vetoed) << "outside the hit bounds: pixel " << c << "," << r << " depth " << s;
        }
        if (s >= lo && s <= hi) continue;
        ++outside;
        int background = 0;
        for (size_t k = 0; k < q.size(); ++k) background += q.VoteOf(k, O + s * D) == Vote::kBackground;
        ASSERT_GE(background, 2) << "pixel " << c << "," << r << " depth " << s;
      }
    }
  // Control: the bounds do cut (16% of the samples here: the figure fills most
  // of this narrow view, and a block of 8x8 pixels takes its cubes' extremes).
  EXPECT_GT(double(outside) / double(all), 0.1);
  // ...and the hit bounds cut more: the samples only one camera vetoes too.
  EXPECT_GT(double(outside_hit - outside) / double(all), 0.1);
  // An eye inside the hull box: cubes behind it are left out, and a cube
  // across its plane gives no bounds at all.
  NovelView inside = view;
  inside.world_from_eye = LookAt(q.hull_box().Center(), q.hull_box().Center() + Eigen::Vector3d(1, 0, 0),
                                 Eigen::Vector3d(0, 0, -1));
  EXPECT_FALSE(grid.DepthBounds(inside, region, &near, &far));
  EXPECT_TRUE(near.empty() && far.empty());
  // A region of fewer pixels than the projections would cost: no bounds.
  EXPECT_FALSE(grid.DepthBounds(view, cv::Rect(0, 0, 40, 30), &near, &far));
}

// The sweep with the grid against the sweep without, bit for bit.
// `unfitted`: planes from 0.3 m in front of the hull box's centre to 0.3 m
// behind, not fitted to the box, so that planes lie inside the hull and on
// the rays' ends.
void ExpectSameSweep(const std::vector<CameraMap>& views, const NovelView& view, int planes, int refine,
                     const cv::Rect& tile, int64_t* skipped, bool unfitted = false) {
  const VolumeQuery with = Query(views, 32), without = Query(views, 0);
  PlaneSweepOptions o;
  o.num_planes = planes;
  if (unfitted) {
    const double dist = (view.world_from_eye.Inverse() * with.hull_box().Center()).z();
    o.fit_planes_to_hull_box = false;
    o.near = dist - 0.3;
    o.far = dist + 0.3;
  }
  const auto depths = SweepPlaneDepths(with, view, o);
  ASSERT_FALSE(depths.empty());
  SweepStats sw, sn;
  const cv::Mat a = PlaneSweepCpu(with, view, depths, tile, &sw, 2, refine);
  const cv::Mat b = PlaneSweepCpu(without, view, depths, tile, &sn, 2, refine);
  EXPECT_EQ(sn.skipped, 0);
  *skipped += sw.skipped;
  ASSERT_EQ(a.size(), b.size());
  const test::DepthDifference diff = test::CompareDepths(a, b);
  EXPECT_EQ(diff.differ, 0) << "refine " << refine << ", " << planes << " planes";
  EXPECT_GT(diff.hull, 20);  // control: the view sees the hull
  // The refined sweep's depths, refined afterwards (the GL backend's path).
  if (refine > 0) {
    cv::Mat ra = PlaneSweepCpu(with, view, depths, tile, nullptr, 1, 0);
    cv::Mat rb = ra.clone();
    RefineSweepDepth(with, view, depths, tile, refine, &ra, 1);
    RefineSweepDepth(without, view, depths, tile, refine, &rb, 1);
    EXPECT_EQ(cv::countNonZero(ra != rb), 0);
  }
}

TEST(EmptySpace, SkippingLeavesTheSweepUnchangedBitForBit) {
  int64_t skipped = 0;
  const NovelView side = test::SphereSideView(120, 90);
  for (const int n : {4, 8}) {
    const auto views = FigureViews(n);
    for (const int refine : {0, 6})
      for (const int planes : {50, 200}) {
        ExpectSameSweep(views, side, planes, refine, {0, 0, 120, 90}, &skipped);
        ExpectSameSweep(views, FarView(160, 120), planes, refine, {0, 0, 160, 120}, &skipped);
      }
    // A tile (the refinement's one-pixel margin) and an eye of a head-mounted
    // display: an asymmetric frustum.
    ExpectSameSweep(views, side, 100, 6, TileRect(1, 2, 120, 90), &skipped);
    StereoOptions so;
    so.width = 96, so.height = 96;
    const StereoViews eyes = MakeStereoViews(side.world_from_eye, so);
    ExpectSameSweep(views, eyes.eye[1], 100, 6, {0, 0, 96, 96}, &skipped);
  }
  // Skewed, distorted cameras.
  const Distortion d{-0.25, 0.08, 0.001, -0.001, -0.01};
  ExpectSameSweep(FigureViews(6, d, 0.02), side, 100, 6, {0, 0, 120, 90}, &skipped);
  EXPECT_GT(skipped, 10000);  // control: the grid answered many of the sweeps' queries
  // Planes inside the hull, one at each end of the rays' parts.
  for (const int refine : {0, 6}) ExpectSameSweep(FigureViews(4), side, 41, refine, {0, 0, 120, 90}, &skipped, true);
}

// An eye inside the hull box (a participant standing in the workspace): no
// depth bounds, the grid's cubes still skipped sample by sample.
TEST(EmptySpace, AnEyeInsideTheHullBoxSweepsTheSame) {
  const auto views = FigureViews(4);
  const VolumeQuery q = Query(views, 32);
  const Eigen::Vector3d eye = q.hull_box().Center() + Eigen::Vector3d(0.5, 0.5, -0.2);
  ASSERT_TRUE(q.hull_box().Contains(eye));
  const NovelView view = NovelView::FromFov(100, 80, 1.4, LookAt(eye, kSphereCentre, Eigen::Vector3d(0, 0, -1)));
  int64_t skipped = 0;
  ExpectSameSweep(views, view, 100, 6, {0, 0, 100, 80}, &skipped);
  EXPECT_GT(skipped, 0);
}

}  // namespace
}  // namespace hullpipe
