// GL twins against their CPU references. Skips (with the reason) only where no
// EGL display exists.
#include <algorithm>

#include <gtest/gtest.h>

#include "hullpipe/gl/backend.h"
#include "hullpipe/gl/egl_context.h"
#include "hullpipe/gl/gl_plane_sweep.h"
#include "hullpipe/gl/gl_triangle_query.h"
#include "hullpipe/geometry/mesh.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/collision/triangle_query.h"
#include "test_util.h"

namespace hullpipe::gl {
namespace {

const Eigen::Vector3d kCentre(0.1, -0.2, -1.0);

class Gl : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    ctx_ = EglContext::TryCreate(&why);
    if (!ctx_) GTEST_SKIP() << "no EGL display: " << why;
  }
  std::optional<EglContext> ctx_;
};

// Compares a GL depth tile with the CPU's: equal planes except at silhouette
// borders where float rounding differs (then one plane apart), at most 0.5%.
void ExpectSweepsMatch(const cv::Mat& gl, const cv::Mat& cpu, double spacing) {
  int hull = 0, differ = 0;
  for (int r = 0; r < cpu.rows; ++r)
    for (int c = 0; c < cpu.cols; ++c) {
      const float a = gl.at<float>(r, c), b = cpu.at<float>(r, c);
      if (std::isfinite(b)) ++hull;
      if (a == b) continue;
      ++differ;
      if (std::isfinite(a) && std::isfinite(b)) {
        EXPECT_LE(std::abs(a - b), spacing * 1.01) << r << "," << c;
      }
    }
  EXPECT_GT(hull, 500);
  EXPECT_LE(differ, hull / 200 + 2) << differ << " of " << hull << " hull pixels differ";
}

TEST_F(Gl, PlaneSweepMatchesCpu) {
  for (const Distortion& d : {Distortion{}, Distortion{-0.3, 0.1, 0.001, -0.001, -0.02}}) {
    const VolumeQuery q(test::SphereViews(4, 200, 150, kCentre, 0.3, d), test::BigBox());
    const NovelView view = NovelView::FromFov(
        160, 120, 0.8, LookAt(kCentre + Eigen::Vector3d(2.0, 1.2, -0.5), kCentre, {0, 0, -1}));
    PlaneSweepOptions o;
    o.num_planes = 50;
    const auto depths = SweepPlaneDepths(q, view, o);
    GlPlaneSweep gl;
    for (const cv::Rect tile : {cv::Rect(0, 0, 160, 120), TileRect(1, 2, 160, 120)}) {
      ExpectSweepsMatch(gl.Sweep(q, view, depths, tile), PlaneSweepCpu(q, view, depths, tile),
                        depths[1] - depths[0]);
    }
  }
}

TEST_F(Gl, PlaneSweepMatchesCpuUnderBothOutOfViewRulesAndMixedResolutions) {
  // Camera 0 is turned so the sphere straddles its image border (unseen there),
  // and the cameras have different resolutions: the GL stencil vote (with the
  // resolve pass counting the cameras that see the point) equals the CPU's.
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Sphere(kCentre, 0.3));
  auto cams = RingCameras(4, 3.0, 1.8, kCentre, 160, 120, 1.0);
  const Eigen::Vector3d C = cams[0].Center();
  const double dist = (kCentre - C).norm();
  cams[0].cam_from_world =
      LookAt(C, kCentre + (kCentre - C).cross(Eigen::Vector3d(0, 0, -1)).normalized() * dist * std::tan(0.55),
             {0, 0, -1})
          .Inverse();
  cams[2] = ScaledCamera(cams[2], 240, 180);
  cams[3] = ScaledCamera(cams[3], 100, 75);
  std::vector<CameraMap> views;
  for (const auto& c : cams) views.push_back({c, RenderExactMap(c, scene)});
  const NovelView view = NovelView::FromFov(
      160, 120, 0.8, LookAt(kCentre + Eigen::Vector3d(2.0, 1.2, -0.5), kCentre, {0, 0, -1}));
  GlPlaneSweep gl;
  for (const OutOfView p : {OutOfView::kOutside, OutOfView::kUnknown}) {
    VolumeQueryOptions qo;
    qo.out_of_view = p;
    const VolumeQuery q(views, test::BigBox(), qo);
    PlaneSweepOptions o;
    o.num_planes = 50;
    const auto depths = SweepPlaneDepths(q, view, o);
    const cv::Rect all(0, 0, 160, 120);
    const cv::Mat cpu = PlaneSweepCpu(q, view, depths, all);
    if (p == OutOfView::kOutside) {
      int hull = 0;
      for (int r = 0; r < 120; ++r)
        for (int c = 0; c < 160; ++c) hull += std::isfinite(cpu.at<float>(r, c));
      EXPECT_GT(hull, 200) << "part of the sphere survives the clip";
    }
    ExpectSweepsMatch(gl.Sweep(q, view, depths, all), cpu, depths[1] - depths[0]);
  }
}

TEST_F(Gl, TriangleQueryMatchesCpu) {
  const VolumeQuery q(test::SphereViews(4, 200, 150, kCentre, 0.3), test::BigBox());
  // An icosphere mesh cutting through the hull: some triangles inside, some out,
  // some across the surface; plus a sub-pixel triangle.
  Rigid3d pose;
  pose.translation = kCentre + Eigen::Vector3d(0.25, 0, 0);
  const TriangleMesh mesh = TriangleMesh::Icosphere(0.2, 2).Transformed(pose);
  std::vector<Triangle> tris;
  for (const auto& t : mesh.triangles)
    tris.push_back({mesh.vertices[size_t(t[0])], mesh.vertices[size_t(t[1])], mesh.vertices[size_t(t[2])]});
  tris.push_back({kCentre, kCentre + Eigen::Vector3d(1e-4, 0, 0), kCentre + Eigen::Vector3d(0, 1e-4, 0)});
  const TriangleQueryOptions o{0.004, 0, 32};
  GlTriangleQuery gl;
  const auto got = gl.Query(q, tris, o);
  ASSERT_EQ(got.size(), tris.size());
  size_t cpu_points = 0, gl_points = 0;
  int gl_unmatched = 0;
  for (size_t i = 0; i < tris.size(); ++i) {
    const auto ref = QueryTriangleCpu(q, tris[i].a, tris[i].b, tris[i].c, o);
    const TriangleViewport vp = MakeTriangleViewport(tris[i].a, tris[i].b, tris[i].c, o);
    // Pixel centres exactly on an edge are inside on the CPU and follow GL's
    // top-left rule on the GPU: at most one pixel per edge row/column differs.
    const int edge_slack = 2 * (vp.width + vp.height);
    EXPECT_NEAR(got[i].pixels_tested, ref.pixels_tested, edge_slack) << "triangle " << i;
    cpu_points += ref.collision_points.size();
    gl_points += got[i].collision_points.size();
    // Positions, not only counts: every GL collision point is a CPU collision
    // point of the same triangle (the same pixel centre, to float precision: the
    // GPU interpolates the world point in float, ~1e-7 relative, well under
    // 1 µm at these distances), except on the edge pixels the rasterisers may
    // assign differently, which are not CPU points at all (at most edge_slack).
    int unmatched = 0;
    for (const auto& p : got[i].collision_points) {
      double best = 1e9;
      for (const auto& r : ref.collision_points) best = std::min(best, (p - r).norm());
      unmatched += best > 1e-5;  // 10 µm; pixels here are 4 mm apart
    }
    EXPECT_LE(unmatched, edge_slack) << "triangle " << i;
    gl_unmatched += unmatched;
    if (int(ref.collision_points.size()) > edge_slack) {
      EXPECT_FALSE(got[i].collision_points.empty()) << "triangle " << i;
    }
  }
  EXPECT_GT(cpu_points, 100u);
  EXPECT_NEAR(double(gl_points), double(cpu_points), 0.03 * double(cpu_points));
  EXPECT_LE(gl_unmatched, int(0.03 * double(gl_points))) << "GL points that are no CPU point";
  EXPECT_EQ(got.back().collision_points.size(), 1u);  // sub-pixel triangle, centroid inside
}

TEST_F(Gl, BackendChoice) {
  EXPECT_EQ(MakeSweepBackend("cpu")->Name(), "cpu");
  const auto a = MakeSweepBackend("auto");
  if (ctx_->IsSoftware()) {
    EXPECT_EQ(a->Name(), "cpu");  // llvmpipe: the CPU is faster
  }
  EXPECT_NE(MakeSweepBackend("gl")->Name().find("gl"), std::string::npos);
  EXPECT_THROW(MakeSweepBackend("vulkan"), std::invalid_argument);
}

}  // namespace
}  // namespace hullpipe::gl
