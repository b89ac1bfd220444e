// GL twins against their CPU references. Skips (with the reason) only where no
// EGL display exists.
#include <algorithm>
#include <cstring>
#include <fstream>
#include <functional>
#include <random>
#include <tuple>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "hullpipe/gl/backend.h"
#include "hullpipe/gl/egl_context.h"
#include "hullpipe/gl/gl_plane_sweep.h"
#include "hullpipe/gl/gl_ray_sweep.h"
#include "hullpipe/gl/gl_texture.h"
#include "hullpipe/gl/gl_triangle_query.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/geometry/mesh.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/collision/triangle_query.h"
#include "hullpipe/models/model_import.h"
#include "hullpipe/scenes/cloth.h"
#include "hullpipe/scenes/model_scene.h"
#include "hullpipe/scenes/virtual_scene.h"
#include "hullpipe/segmentation/video_rig.h"
#include "gl_upload.h"  // private to hullpipe_gl (gl/src): its packing is tested here
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

// Without distortion, with it, and with a skewed K (0.06 fx) on top of it.
const std::vector<std::pair<Distortion, double>> kLenses = {
    {Distortion{}, 0.0}, {Distortion{-0.3, 0.1, 0.001, -0.001, -0.02}, 0.0},
    {Distortion{-0.3, 0.1, 0.001, -0.001, -0.02}, 0.06}};

TEST_F(Gl, PlaneSweepMatchesCpu) {
  for (const auto& [d, skew] : kLenses) {
    const VolumeQuery q(test::SphereViews(4, 200, 150, kCentre, 0.3, d, skew), test::BigBox());
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
  for (const double skew : {0.0, 0.06}) {
  SCOPED_TRACE("skew " + std::to_string(skew));
  const VolumeQuery q(test::SphereViews(4, 200, 150, kCentre, 0.3, {}, skew), test::BigBox());
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
}

TEST_F(Gl, TriangleQueryWithMoreMasksThanTheFirstBuffer) {
  // 300 triangles inside the sphere in 10x10 viewports: ~15,000 inside points,
  // their masks (4 words each) more than a 64-word buffer holds: the pass runs
  // again with room. Same points as the CPU, and the batch's counts agree with
  // the points it makes.
  const VolumeQuery q(test::SphereViews(4, 200, 150, kCentre, 0.3), test::BigBox());
  std::vector<Triangle> tris;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d o = kCentre + Eigen::Vector3d(0.01 * (i % 20) - 0.1, 0.01 * (i / 20) - 0.075, 0.0);
    tris.push_back({o, o + Eigen::Vector3d(0.008, 0, 0), o + Eigen::Vector3d(0, 0.008, 0.001)});
  }
  const TriangleQueryOptions o{0.002, 10, 64};
  for (const size_t words : {size_t(64), size_t(1) << 16}) {
    GlTriangleQuery gl(words);
    const TriangleBatchResult batch = gl.QueryBatch(q, tris, o);
    const auto got = batch.All();
    size_t points = 0, cpu_points = 0;
    for (size_t i = 0; i < tris.size(); ++i) {
      const auto ref = QueryTriangleCpu(q, tris[i].a, tris[i].b, tris[i].c, o);
      EXPECT_NEAR(got[i].pixels_tested, ref.pixels_tested, 40) << i;  // edge pixels, as above
      EXPECT_NEAR(double(got[i].collision_points.size()), double(ref.collision_points.size()), 40) << i;
      EXPECT_EQ(int(got[i].collision_points.size()), batch.inside(i)) << i;
      points += got[i].collision_points.size();
      cpu_points += ref.collision_points.size();
    }
    EXPECT_GT(points, 8000u) << "words " << words;
    // In total, edge pixels cancel out: within 3% of the CPU (as above), so a
    // pass or a buffer refill that lost points fails.
    EXPECT_NEAR(double(points), double(cpu_points), 0.03 * double(cpu_points)) << "words " << words;
  }
}

// The batched GPU query against the CPU's on the scenes' own meshes cutting the
// synthetic figure's hull: Debian's 2CylinderEngine (110,336 triangles, real
// size, 4-mm pixels as the engine scene) and the curtain (720 triangles, 1-cm
// pixels). Per triangle the counts differ only on edge pixels (float against
// double: at most 2 (w + h)); in all, the colliding triangles and the points
// agree within 1%, and every GPU point is a CPU point of its triangle (10 um).
TEST_F(Gl, TheBatchedQueryFindsTheCpusCollisionsOnTheEngineAndTheCurtain) {
  const std::string engine_file = "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
  if (!std::ifstream(engine_file)) GTEST_SKIP() << engine_file << " missing (assimp-testmodels)";
  const auto cams = RingCameras(4, 3.0, 1.8, Eigen::Vector3d(0.2, 0, -1.0), 320, 240, 1.0);
  const VolumeQuery q = test::HullOf(AnimatedFigure(0.0), cams);
  const Eigen::Vector3d centre = q.hull_box().Center();
  auto centred = [&](std::vector<Triangle> tris) {
    Aabb box;
    for (const auto& t : tris) box.Extend(t.a), box.Extend(t.b), box.Extend(t.c);
    const Eigen::Vector3d shift = centre - box.Center();
    for (auto& t : tris) t.a += shift, t.b += shift, t.c += shift;
    return tris;
  };
  std::vector<Triangle> engine;
  for (const ImportedPart& p : ImportModelInProcess(engine_file).parts)
    for (const auto& t : p.triangles)
      engine.push_back({p.vertices[size_t(t[0])].cast<double>() * 1e-3, p.vertices[size_t(t[1])].cast<double>() * 1e-3,
                        p.vertices[size_t(t[2])].cast<double>() * 1e-3});
  const TriangleMesh cloth_mesh = ClothSimulation(ClothConfig{}, Eigen::Vector3d(0, 0, 9.81)).Mesh();
  std::vector<Triangle> curtain;
  for (const auto& t : cloth_mesh.triangles)
    curtain.push_back({cloth_mesh.vertices[size_t(t[0])], cloth_mesh.vertices[size_t(t[1])],
                       cloth_mesh.vertices[size_t(t[2])]});
  GlTriangleQuery gl;
  for (const auto& [name, tris, o] : {std::tuple{"engine", centred(engine), TriangleQueryOptions{0.004, 0, 32}},
                                      std::tuple{"curtain", centred(curtain), ClothConfig{}.collision}}) {
    SCOPED_TRACE(name);
    const auto cpu = QueryTrianglesCpu(q, tris, o, 2);
    const TriangleBatchResult batch = gl.QueryBatch(q, tris, o);
    ASSERT_EQ(batch.size(), tris.size());
    size_t cpu_colliding = 0, gl_colliding = 0, differ = 0, cpu_points = 0, gl_points = 0, unmatched = 0;
    for (size_t i = 0; i < tris.size(); ++i) {
      const TriangleViewport vp = MakeTriangleViewport(tris[i].a, tris[i].b, tris[i].c, o);
      const int edge_slack = 2 * (vp.width + vp.height);
      EXPECT_NEAR(batch.pixels_tested(i), cpu[i].pixels_tested, edge_slack) << i;
      const bool a = !cpu[i].collision_points.empty(), b = batch.inside(i) > 0;
      cpu_colliding += a, gl_colliding += b, differ += a != b;
      if (!b) continue;
      const auto points = batch.Points(i);
      gl_points += points.size();
      for (const auto& p : points) {
        double best = 1e9;
        for (const auto& r : cpu[i].collision_points) best = std::min(best, (p - r).norm());
        unmatched += best > 1e-5;
      }
    }
    for (const auto& r : cpu) cpu_points += r.collision_points.size();
    EXPECT_GT(cpu_colliding, 20u) << "the mesh cuts the hull";
    EXPECT_LE(double(differ), 0.01 * double(cpu_colliding) + 1) << cpu_colliding << " vs " << gl_colliding;
    EXPECT_NEAR(double(gl_points), double(cpu_points), 0.01 * double(cpu_points) + 2);
    EXPECT_LE(double(unmatched), 0.01 * double(gl_points) + 1);
  }
}

TEST_F(Gl, BackendChoice) {
  EXPECT_EQ(MakeSweepBackend("cpu")->Name(), "cpu");
  const auto a = MakeSweepBackend("auto");
  if (ctx_->IsSoftware()) {
    EXPECT_EQ(a->Name(), "cpu");  // llvmpipe: the CPU is faster
    EXPECT_NE(a->reason().find("software"), std::string::npos) << a->reason();
  } else {
    EXPECT_NE(a->Name().find("gl march"), std::string::npos) << a->Name();
  }
  const auto g = MakeSweepBackend("gl");
  EXPECT_NE(g->Name().find("gl march"), std::string::npos);
  ASSERT_NE(GlInfoOf(*g), nullptr);
  EXPECT_FALSE(GlInfoOf(*g)->vendor.empty());
  EXPECT_NE(GlInfoOf(*g)->version.find("4."), std::string::npos) << GlInfoOf(*g)->version;
  BackendOptions o;
  o.name = "gl";
  o.gl_method = "stencil";
  EXPECT_NE(MakeSweepBackend(o)->Name().find("gl stencil"), std::string::npos);
  EXPECT_THROW(MakeSweepBackend("vulkan"), std::invalid_argument);
  o.gl_method = "compute";
  EXPECT_THROW(MakeSweepBackend(o), std::invalid_argument);
}

TEST_F(Gl, DeviceSelection) {
  // The context names its renderer and how EGL reached it; a device index past
  // the list fails with a line naming the flag under `gl` and falls back under `auto`.
  EXPECT_FALSE(ctx_->info().renderer.empty());
  EXPECT_FALSE(ctx_->info().source.empty());
  EXPECT_NE(ctx_->info().Summary().find(ctx_->info().renderer), std::string::npos);
  const std::vector<EglDeviceInfo> devices = ListEglDevices();
  for (size_t i = 0; i < devices.size(); ++i) EXPECT_EQ(devices[i].index, int(i));
  BackendOptions o;
  o.name = "gl";
  o.gl_device = 63;
  try {
    MakeSweepBackend(o);
    ADD_FAILURE() << "device 63 accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("--gl-device 63"), std::string::npos) << e.what();
  }
  o.name = "auto";
  const auto a = MakeSweepBackend(o);
  EXPECT_EQ(a->Name(), "cpu");
  EXPECT_NE(a->reason().find("--gl-device 63"), std::string::npos) << a->reason();
  // Each listed device either gives a context or says why (positive control: the
  // default choice above made one).
  for (const auto& d : devices) {
    std::string why;
    auto c = EglContext::TryCreate(EglOptions{d.index}, &why);
    if (c) {
      EXPECT_NE(c->info().source.find("EGL device " + std::to_string(d.index)), std::string::npos);
    } else {
      EXPECT_FALSE(why.empty());
    }
  }
  ctx_->MakeCurrent();
}

// Compares a GPU depth tile with the CPU's: the march is the CPU's algorithm in
// floats, so the two differ only where float rounding (the GPU's division and
// box clip in float, the CPU's ray in double) flips a point at a silhouette or a
// plane at the hull box's face. Without refinement such a flip moves the depth by
// one plane (bounded here by `spacing`, or 0 to skip); with refinement a flipped
// near miss on a thin part can move it to the hull behind, so only the count is
// bounded. At most `max_fraction` of the hull pixels may differ by more than 1 µm.
void ExpectMarchMatches(const cv::Mat& gl, const cv::Mat& cpu, double spacing, double max_fraction,
                        const std::string& what, int min_hull = 500) {
  int hull = 0, differ = 0;
  for (int r = 0; r < cpu.rows; ++r)
    for (int c = 0; c < cpu.cols; ++c) {
      const float a = gl.at<float>(r, c), b = cpu.at<float>(r, c);
      if (std::isfinite(b)) ++hull;
      if (a == b || std::abs(a - b) <= 1e-6f) continue;
      ++differ;
      if (spacing > 0 && std::isfinite(a) && std::isfinite(b)) {
        EXPECT_LE(std::abs(a - b), spacing * 1.01) << what << " at " << r << "," << c;
      }
    }
  EXPECT_GT(hull, min_hull) << what;
  EXPECT_LE(differ, int(max_fraction * hull) + 2) << what << ": " << differ << " of " << hull << " hull pixels differ";
}

// A hard scene for the march: a sphere, a thin capsule (thinner than the plane
// spacing, where refinement's near-miss scans and silhouette pass matter) and a
// torus (a hole and grazing rays), under distortion.
std::vector<CameraMap> HardViews(int w, int h, const Distortion& d, double skew = 0) {
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Sphere(kCentre, 0.22));
  scene.shapes.push_back(Shape::Capsule(kCentre + Eigen::Vector3d(-0.4, 0.3, 0.1),
                                        kCentre + Eigen::Vector3d(0.4, 0.35, -0.2), 0.012));
  scene.shapes.push_back(Shape::Torus(kCentre + Eigen::Vector3d(0.0, -0.35, 0.0), 0.15, 0.04));
  std::vector<CameraMap> views;
  for (const auto& c : test::WithSkew(RingCameras(5, 3.0, 1.8, kCentre, w, h, 1.0, d), skew))
    views.push_back({c, RenderExactMap(c, scene)});
  return views;
}

// The march tests' cases: the hard scene under each of `lenses`, both
// out-of-view rules, 30 and 100 planes, without and with refinement, a whole
// 200x150 view and a tile of it. each_case(query, depths, refine, tile, what)
// for every case; each_query(query, what) once per query, after its cases.
// The query is uploaded to `march` before its cases.
template <class Case, class Query>
void ForEachHardCase(GlRaySweep& march, const NovelView& view,
                     const std::vector<std::pair<Distortion, double>>& lenses, Case each_case, Query each_query) {
  for (const auto& [d, skew] : lenses) {
    for (const OutOfView p : {OutOfView::kUnknown, OutOfView::kOutside}) {
      VolumeQueryOptions qo;
      qo.out_of_view = p;
      const VolumeQuery q(HardViews(240, 180, d, skew), test::BigBox(), qo);
      march.Upload(q);
      const std::string lens =
          "k1=" + std::to_string(d[0]) + " skew=" + std::to_string(skew) + " rule=" + std::to_string(int(p));
      for (const int planes : {30, 100}) {
        PlaneSweepOptions o;
        o.num_planes = planes;
        const auto depths = SweepPlaneDepths(q, view, o);
        for (const int refine : {0, 6})
          for (const cv::Rect tile : {cv::Rect(0, 0, 200, 150), TileRect(1, 2, 200, 150)})
            each_case(q, depths, refine, tile,
                      lens + " planes=" + std::to_string(planes) + " refine=" + std::to_string(refine) +
                          " tile y=" + std::to_string(tile.y));
      }
      each_query(q, lens);
    }
  }
}

TEST_F(Gl, RayMarchSweepMatchesCpuWithAndWithoutRefinement) {
  GlRaySweep march;
  const NovelView view = NovelView::FromFov(
      200, 150, 0.8, LookAt(kCentre + Eigen::Vector3d(2.0, 1.2, -0.5), kCentre, {0, 0, -1}));
  ForEachHardCase(
      march, view, kLenses,
      [&](const VolumeQuery& q, const std::vector<double>& depths, int refine, const cv::Rect& tile,
          const std::string& what) {
        // Without refinement only silhouette rounding differs (the stencil GL
        // sweep's 0.5%); refinement bisects in floats on both sides, each
        // bisection step another chance for a border point to round the other way.
        ExpectMarchMatches(march.Sweep(q, view, depths, tile, refine),
                           PlaneSweepCpu(q, view, depths, tile, nullptr, 1, refine),
                           refine ? 0 : depths[1] - depths[0], refine ? 0.01 : 0.005, what);
      },
      [](const VolumeQuery&, const std::string&) {});
}

TEST_F(Gl, RayMarchRefinementIsCloserToTheSurfaceThanThePlanes) {
  // Refinement on the GPU does its job, not only the CPU's arithmetic: depth
  // error against the exact sphere falls from ~half a plane spacing to under 1%
  // of it.
  const VolumeQuery q(test::SphereViews(8, 320, 240, kCentre, 0.3), test::BigBox());
  const NovelView view = NovelView::FromFov(
      160, 120, 0.8, LookAt(kCentre + Eigen::Vector3d(2.0, 1.2, -0.5), kCentre, {0, 0, -1}));
  PlaneSweepOptions o;
  o.num_planes = 40;
  const auto depths = SweepPlaneDepths(q, view, o);
  const double spacing = depths[1] - depths[0];
  GlRaySweep march;
  march.Upload(q);
  const cv::Mat plain = march.Sweep(q, view, depths, {0, 0, 160, 120}, 0);
  const cv::Mat refined = march.Sweep(q, view, depths, {0, 0, 160, 120}, 8);
  const cv::Mat cpu = PlaneSweepCpu(q, view, depths, {0, 0, 160, 120}, nullptr, 1, 8);
  std::vector<double> err_plain, err_refined;
  for (int r = 0; r < 120; ++r)
    for (int c = 0; c < 160; ++c) {
      const float a = plain.at<float>(r, c), b = refined.at<float>(r, c), ref = cpu.at<float>(r, c);
      if (!std::isfinite(a) || !std::isfinite(b) || !std::isfinite(ref)) continue;
      err_plain.push_back(std::abs(a - ref));
      err_refined.push_back(std::abs(b - ref));
    }
  ASSERT_GT(err_plain.size(), 1500u);
  std::nth_element(err_plain.begin(), err_plain.begin() + long(err_plain.size() / 2), err_plain.end());
  std::nth_element(err_refined.begin(), err_refined.begin() + long(err_refined.size() / 2), err_refined.end());
  EXPECT_GT(err_plain[err_plain.size() / 2], 0.2 * spacing);
  EXPECT_LT(err_refined[err_refined.size() / 2], 0.01 * spacing);
}

TEST_F(Gl, RayMarchUploadsDoNotMixFramesets) {
  // Two framesets uploaded in turn through the two pixel buffers, three rounds:
  // each sweep sees its own maps (a ring that handed a buffer back too early
  // would show the other sphere).
  const VolumeQuery a(test::SphereViews(4, 200, 150, kCentre, 0.3), test::BigBox());
  const VolumeQuery b(test::SphereViews(4, 200, 150, kCentre + Eigen::Vector3d(0.2, 0, 0), 0.2), test::BigBox());
  const NovelView view = NovelView::FromFov(
      160, 120, 0.8, LookAt(kCentre + Eigen::Vector3d(2.0, 1.2, -0.5), kCentre, {0, 0, -1}));
  GlRaySweep march;
  for (int round = 0; round < 3; ++round)
    for (const VolumeQuery* q : {&a, &b}) {
      PlaneSweepOptions o;
      const auto depths = SweepPlaneDepths(*q, view, o);
      march.Upload(*q);
      ExpectMarchMatches(march.Sweep(*q, view, depths, {0, 0, 160, 120}),
                         PlaneSweepCpu(*q, view, depths, {0, 0, 160, 120}), depths[1] - depths[0], 0.005,
                         "round " + std::to_string(round));
    }
  EXPECT_THROW(march.Sweep(VolumeQuery(test::SphereViews(3, 200, 150, kCentre, 0.3), test::BigBox()), view,
                           {1.0, 2.0}, {0, 0, 16, 16}),
               std::invalid_argument);
}

// Narrowing the march to where at most one camera's object rectangle vetoes
// (GlRaySweep::set_narrowing) changes no depth, to the bit: the hard scene's
// sphere, thin capsule and torus under each lens (undistorted with and without
// skew, distorted with and without), both out-of-view rules, 30 and 100
// planes, with and without refinement, a whole view and a tile, and the
// visibility maps' several views in one dispatch. It must skip points where it
// can (undistorted cameras: at least 20% fewer plane points asked, the
// control that it is on) and skip none where it cannot (every camera
// distorted). Narrowing by one camera's veto instead of two fails it (near
// misses are lost).
TEST_F(Gl, RayMarchNarrowedToTheObjectRectanglesGivesTheSameDepths) {
  GlRaySweep march;
  march.set_counting(true);
  const NovelView view = NovelView::FromFov(
      200, 150, 0.8, LookAt(kCentre + Eigen::Vector3d(2.0, 1.2, -0.5), kCentre, {0, 0, -1}));
  auto lenses = kLenses;
  lenses.push_back({Distortion{}, 0.06});
  int compared = 0;
  ForEachHardCase(
      march, view, lenses,
      [&](const VolumeQuery& q, const std::vector<double>& depths, int refine, const cv::Rect& tile,
          const std::string& what) {
        march.set_narrowing(false);
        const cv::Mat whole = march.Sweep(q, view, depths, tile, refine);
        const uint64_t asked_whole = march.points_asked();
        march.set_narrowing(true);
        const cv::Mat narrowed = march.Sweep(q, view, depths, tile, refine);
        const uint64_t asked_narrowed = march.points_asked();
        ASSERT_EQ(whole.size(), narrowed.size());
        EXPECT_EQ(std::memcmp(whole.data, narrowed.data, whole.total() * sizeof(float)), 0) << what;
        EXPECT_GT(cv::countNonZero(whole < 1e30f), 500) << what;
        EXPECT_GT(asked_whole, 0u) << what;
        if (q.fast()[0].distorted)
          EXPECT_EQ(asked_narrowed, asked_whole) << what;
        else
          EXPECT_LT(double(asked_narrowed), 0.8 * double(asked_whole)) << what;
        ++compared;
      },
      [&](const VolumeQuery& q, const std::string& what) {
        // The visibility maps: a view from each camera, swept in one dispatch.
        std::vector<NovelView> views;
        std::vector<std::vector<double>> view_depths;
        for (size_t c = 0; c < q.size(); ++c) {
          const Camera& cam = q.views()[c].camera;
          views.push_back(NovelView::FromFov(80, 60, 0.9, cam.cam_from_world.Inverse()));
          PlaneSweepOptions o;
          o.num_planes = 48;
          view_depths.push_back(SweepPlaneDepths(q, views.back(), o));
        }
        std::vector<cv::Mat> whole;
        march.set_narrowing(false);
        march.SweepViews(q, views, view_depths, 6);
        for (size_t k = 0; k < views.size(); ++k) whole.push_back(march.ReadView(k));
        march.set_narrowing(true);
        march.SweepViews(q, views, view_depths, 6);
        for (size_t k = 0; k < views.size(); ++k) {
          const cv::Mat narrowed = march.ReadView(k);
          EXPECT_EQ(std::memcmp(whole[k].data, narrowed.data, narrowed.total() * sizeof(float)), 0)
              << "visibility view " << k << " " << what;
          EXPECT_GT(cv::countNonZero(narrowed < 1e30f), 50) << what;
        }
      });
  EXPECT_EQ(compared, 4 * 2 * 2 * 2 * 2);
}

// The maps' upload as bits (LayerUploader::Packing::kBits, what the march and
// the triangle query read), read back texel by texel: within each layer's
// rectangle every pixel's bit is its map's, the rest of the texels that hold
// the rectangle are the map's own pixels too, pixels past the width are 0, and
// texels outside the rectangles keep an earlier upload's contents. Widths and
// rectangles that start and end inside a word, on its edges and at the layer's.
TEST_F(Gl, MapsGoUpAsBitsOfTheirObjectPixels) {
  std::mt19937 rng(5);
  LayerUploader up(GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, CV_8UC1, LayerUploader::Packing::kBits);
  const std::vector<cv::Size> sizes = {{70, 5}, {64, 3}, {33, 4}, {1, 2}, {97, 6}};
  auto noise = [&](cv::Size s, int value) {
    cv::Mat m(s, CV_8UC1);
    for (auto it = m.begin<uint8_t>(); it != m.end<uint8_t>(); ++it) *it = rng() % 2 ? uint8_t(value) : 0;
    return m;
  };
  std::vector<cv::Mat> first, second;
  for (const cv::Size& s : sizes)
    first.push_back(noise(s, 255)), second.push_back(noise(s, 1));  // any non-zero is object
  up.Upload(first);
  EXPECT_EQ(up.last_bytes(), size_t(4 * (3 * 5 + 2 * 3 + 2 * 4 + 1 * 2 + 4 * 6)));
  const std::vector<cv::Rect> rects = {{31, 1, 2, 3}, {32, 0, 32, 3}, {0, 0, 33, 4}, {0, 0, 0, 0}, {33, 2, 64, 3}};
  up.Upload(second, &rects);
  const int tw = 4, th = 6;  // the array: the widest layer's 97 pixels in 4 texels, the tallest's 6 rows
  std::vector<uint32_t> got(size_t(tw * th * int(sizes.size())));
  glGetTextureImage(up.texture(), 0, GL_RED_INTEGER, GL_UNSIGNED_INT, GLsizei(got.size() * 4), got.data());
  ASSERT_EQ(glGetError(), GLenum(GL_NO_ERROR));
  int checked = 0;
  for (size_t l = 0; l < sizes.size(); ++l) {
    const cv::Rect& r = rects[l];
    for (int y = 0; y < sizes[l].height; ++y)
      for (int tx = 0; tx < (sizes[l].width + 31) / 32; ++tx) {
        // The texel went up in the second upload when it holds a pixel of the rectangle.
        const bool now =
            r.area() > 0 && y >= r.y && y < r.y + r.height && 32 * tx < r.x + r.width && 32 * tx + 32 > r.x;
        const cv::Mat& map = now ? second[l] : first[l];
        const uint32_t word = got[size_t((int(l) * th + y) * tw + tx)];
        for (int i = 0; i < 32; ++i) {
          const int x = 32 * tx + i;
          const bool object = x < sizes[l].width && map.at<uint8_t>(y, x) != 0;
          EXPECT_EQ(((word >> i) & 1u) != 0, object)
              << "layer " << l << " pixel " << x << "," << y << (now ? " (second)" : " (first)");
          ++checked;
        }
      }
  }
  EXPECT_EQ(checked, 32 * (3 * 5 + 2 * 3 + 2 * 4 + 1 * 2 + 4 * 6));
  // Control: the two uploads differ in the texels the rectangles hold.
  EXPECT_GT(cv::countNonZero((first[4] != 0) != (second[4] != 0)), 50);
}

// Colour images go up as three one-byte texels a pixel (Packing::kChannels),
// read back: within each rectangle texel (3 x + i, y) is channel i of pixel
// (x, y); outside it an earlier upload's. An image wider than the GL's largest
// texture side / 3 is refused, named, before anything goes up.
TEST_F(Gl, ImagesGoUpAsThreeTexelsAPixel) {
  LayerUploader up(GL_R8UI, GL_RED_INTEGER, GL_UNSIGNED_BYTE, CV_8UC3, LayerUploader::Packing::kChannels);
  std::vector<cv::Mat> first(2), second(2);
  for (auto* v : {&first, &second})
    for (int k = 0; k < 2; ++k) {
      (*v)[size_t(k)].create(4, 7 + 3 * k, CV_8UC3);
      cv::randu((*v)[size_t(k)], 0, 256);
    }
  up.Upload(first);
  EXPECT_EQ(up.last_bytes(), size_t(3 * (4 * 7 + 4 * 10)));
  const std::vector<cv::Rect> rects = {{2, 1, 3, 2}, {9, 0, 1, 4}};
  up.Upload(second, &rects);
  EXPECT_EQ(up.last_bytes(), size_t(3 * (3 * 2 + 1 * 4)));
  const int tw = 30, th = 4;
  std::vector<uint8_t> got(size_t(tw * th * 2));
  glPixelStorei(GL_PACK_ALIGNMENT, 1);  // rows of 30 bytes, unpadded
  glGetTextureImage(up.texture(), 0, GL_RED_INTEGER, GL_UNSIGNED_BYTE, GLsizei(got.size()), got.data());
  ASSERT_EQ(glGetError(), GLenum(GL_NO_ERROR));
  for (int k = 0; k < 2; ++k)
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < first[size_t(k)].cols; ++x) {
        const bool now = rects[size_t(k)].contains(cv::Point(x, y));
        const cv::Vec3b want = (now ? second : first)[size_t(k)].at<cv::Vec3b>(y, x);
        for (int i = 0; i < 3; ++i)
          EXPECT_EQ(got[size_t((k * th + y) * tw + 3 * x + i)], want[i]) << "image " << k << " pixel " << x << "," << y;
      }
  GLint max_side = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_side);
  LayerUploader wide(GL_R8UI, GL_RED_INTEGER, GL_UNSIGNED_BYTE, CV_8UC3, LayerUploader::Packing::kChannels);
  try {
    wide.Upload({cv::Mat(1, max_side / 3 + 1, CV_8UC3, cv::Scalar(1, 2, 3))});
    ADD_FAILURE() << "an image of " << max_side / 3 + 1 << " pixels went up";
  } catch (const GlError& e) {
    EXPECT_NE(std::string(e.what()).find("exceed this GL's largest texture"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(wide.Upload({cv::Mat(1, max_side / 3, CV_8UC3, cv::Scalar(1, 2, 3))}));  // control: the widest
}

// Colour images for the sphere cameras: a pattern that differs per camera and
// varies smoothly (so bilinear sampling matters) at half the maps' resolution.
std::vector<CameraImage> PatternImages(const std::vector<CameraMap>& views) {
  std::vector<CameraImage> images;
  for (size_t k = 0; k < views.size(); ++k) {
    cv::Mat img(views[k].camera.height / 2, views[k].camera.width / 2, CV_8UC3);
    for (int r = 0; r < img.rows; ++r)
      for (int c = 0; c < img.cols; ++c)
        img.at<cv::Vec3b>(r, c) = cv::Vec3b(uint8_t((c * 3 + 40 * k) % 256), uint8_t((r * 5) % 256),
                                            uint8_t(((r + c) * 2 + 60 * k) % 256));
    images.push_back({views[k].camera, img});
  }
  return images;
}

// Compares GPU and CPU colours of one tile: at most 1 level apart (float against
// double arithmetic in the bilinear blend and the weights, then rounding) on all
// but `max_fraction` of the pixels, where a camera's visibility or its place among
// the best two may flip at a rounding border (none did on these scenes; a wrong
// camera choice or sample offset changes most pixels of the pattern by > 1).
void ExpectColoursMatch(const cv::Mat& gl, const cv::Mat& cpu, double max_fraction, const std::string& what) {
  ASSERT_EQ(gl.size(), cpu.size());
  ASSERT_EQ(gl.type(), CV_8UC3);
  int coloured = 0, differ = 0;
  for (int r = 0; r < cpu.rows; ++r)
    for (int c = 0; c < cpu.cols; ++c) {
      const cv::Vec3b a = gl.at<cv::Vec3b>(r, c), b = cpu.at<cv::Vec3b>(r, c);
      coloured += b != cv::Vec3b(0, 0, 0);
      int worst = 0;
      for (int i = 0; i < 3; ++i) worst = std::max(worst, std::abs(int(a[i]) - int(b[i])));
      differ += worst > 1;
    }
  EXPECT_GT(coloured, 1000) << what;
  EXPECT_LE(differ, int(max_fraction * coloured) + 2) << what << ": " << differ << " of " << coloured;
}

// The sphere seen by four cameras with pattern images, a 200x150 view of it, its
// default planes, and the visibility sweep's settings (recon's: 48 planes).
struct TexturedSphere {
  explicit TexturedSphere(const Distortion& d, double skew = 0)
      : views(test::SphereViews(4, 240, 180, kCentre, 0.3, d, skew)),
        q(views, test::BigBox()),
        images(PatternImages(views)),
        view(NovelView::FromFov(200, 150, 0.8,
                                LookAt(kCentre + Eigen::Vector3d(2.0, 1.2, -0.5), kCentre, {0, 0, -1}))),
        depths(SweepPlaneDepths(q, view, PlaneSweepOptions{})) {
    for (const auto& im : images) cams.push_back(im.camera);
    vo.num_planes = 48;
  }
  std::vector<CameraMap> views;
  VolumeQuery q;
  std::vector<CameraImage> images;
  NovelView view;
  std::vector<double> depths;
  std::vector<Camera> cams;
  PlaneSweepOptions vo;
};

// The textured sphere with a distorted lens, without skew and with, and its
// cameras' visibility maps: f(sphere, visibility) for each.
void ForEachDistortedSphere(const std::function<void(const TexturedSphere&, const HullVisibility&)>& f) {
  for (const double skew : {0.0, 0.06}) {
    SCOPED_TRACE("skew " + std::to_string(skew));
    const TexturedSphere t(Distortion{-0.2, 0.05, 0.001, -0.001, 0}, skew);
    f(t, ComputeHullVisibility(t.q, t.cams, 80, t.vo, 4));
  }
}

TEST_F(Gl, TextureMatchesCpuWithAndWithoutVisibility) {
  ForEachDistortedSphere([](const TexturedSphere& t, const HullVisibility& vis) {
    const auto& [views, q, images, view, depths, cams, vo] = t;
    GlTexture tex;
    tex.UploadImages(images);
    for (const cv::Rect tile : {cv::Rect(0, 0, 200, 150), TileRect(0, 2, 200, 150)}) {
      const cv::Mat depth = PlaneSweepCpu(q, view, depths, tile, nullptr, 1, 4);
      ExpectColoursMatch(tex.Texture(depth, tile, view, images), TextureHull(depth, tile, view, images), 0.005,
                         "no visibility");
      ExpectColoursMatch(tex.Texture(depth, tile, view, images, {}, &vis),
                         TextureHull(depth, tile, view, images, {}, &vis), 0.005, "visibility");
    }
  });
}

TEST_F(Gl, TextureFromTheImagesObjectRectanglesIsTheWholeImagesTexture) {
  // Each image uploaded only around its camera's object pixels
  // (ObjectImageRects) textures the hull exactly as the whole images do: a
  // hull point's samples lie there. Before each upload the texture array holds
  // other images (a flat colour), so a sample read outside the uploaded part
  // would show. Too small a part, or a depth off the hull, is caught by the
  // pass itself: the image goes up whole and the pass runs again (the positive
  // control that the catch works: its colours still equal the whole images').
  ForEachDistortedSphere([](const TexturedSphere& t, const HullVisibility& vis) {
    const auto& [views, q, images, view, depths, cams, vo] = t;
    std::vector<CameraImage> flat = images;
    for (auto& im : flat) im.image = cv::Mat(im.image.size(), CV_8UC3, cv::Scalar(7, 200, 31));
    const cv::Rect tile(0, 0, 200, 150);
    const cv::Mat on_hull = PlaneSweepCpu(q, view, depths, tile, nullptr, 1, 4);
    cv::Mat off_hull(on_hull.size(), CV_32FC1, cv::Scalar(2.0f));  // eye z 2 m: no point of the hull
    GlTexture whole, part;
    whole.UploadImages(images);
    const size_t whole_bytes = whole.uploaded_bytes();
    const std::vector<cv::Rect> rects = GlTexture::ObjectImageRects(q, images);
    ASSERT_EQ(rects.size(), images.size());
    std::vector<cv::Rect> halves;
    for (const cv::Rect& r : rects) halves.push_back(cv::Rect(r.x, r.y, r.width, r.height / 2));
    struct Case {
      const char* what;
      const std::vector<cv::Rect>* rects;
      const cv::Mat* depth;
      bool refetch;
    };
    for (const Case& c : {Case{"object rectangles", &rects, &on_hull, false},
                          Case{"half rectangles", &halves, &on_hull, true},
                          Case{"a depth off the hull", &rects, &off_hull, true}}) {
      SCOPED_TRACE(c.what);
      for (const bool with_vis : {false, true}) {
        part.UploadImages(flat);
        (void)part.Texture(*c.depth, tile, view, flat, {}, with_vis ? &vis : nullptr);
        part.UploadImages(images, c.rects);
        EXPECT_LT(part.uploaded_bytes(), whole_bytes * (c.rects == &rects ? 0.6 : 0.35));
        const int64_t before = part.refetched_images();
        const cv::Mat got = part.Texture(*c.depth, tile, view, images, {}, with_vis ? &vis : nullptr);
        const cv::Mat want = whole.Texture(*c.depth, tile, view, images, {}, with_vis ? &vis : nullptr);
        EXPECT_GT(cv::countNonZero(want.reshape(1)), 1000);
        EXPECT_EQ(cv::norm(got, want, cv::NORM_INF), 0.0) << (with_vis ? "with" : "without") << " visibility";
        if (c.refetch)
          EXPECT_GT(part.refetched_images(), before);
        else
          EXPECT_EQ(part.refetched_images(), before);
      }
    }
    EXPECT_EQ(whole.refetched_images(), 0);
  });
}

// The same on real rigs' frames (segmented maps, skewed and distorted lenses,
// images at the maps' size): the published dome (20 cameras) and the Utrecht
// rig. The hull's pixels, textured with the visibility test from images
// uploaded only around their object pixels, are the whole images' to the bit,
// and no image had to go up whole again.
TEST_F(Gl, RealRigsTextureFromTheImagesObjectRectanglesAsFromWholeImages) {
  for (const std::string& rig : test::RealRigs()) {
    const test::RealRigFrame first = test::FirstFrameOf(rig);
    if (!first.source) GTEST_SKIP() << rig << " not found (../shared beside the clone)";
    SCOPED_TRACE(rig);
    const auto& [src, f, views] = first;
    const std::vector<Camera>& cams = src->cameras();
    std::vector<CameraImage> images;
    for (size_t i = 0; i < cams.size(); ++i) images.push_back({cams[i], f.images[i]});
    const VolumeQuery q(views, src->workspace());
    const Aabb& box = q.hull_box();
    ASSERT_FALSE(box.empty());
    const Eigen::Vector3d eye =
        box.Center() + Eigen::Vector3d(0.8, 0.6, 0.5).normalized() * 1.5 * (box.max - box.min).norm();
    const Eigen::Vector3d up = -src->cameras()[0].cam_from_world.rotation.row(1).transpose();  // camera 0's up
    const NovelView view = NovelView::FromFov(160, 120, 1.0, LookAt(eye, box.Center(), up));
    PlaneSweepOptions o, vo;
    o.num_planes = 100;
    vo.num_planes = 48;
    const cv::Rect tile(0, 0, view.width, view.height);
    const cv::Mat depth = PlaneSweepCpu(q, view, SweepPlaneDepths(q, view, o), tile, nullptr, 2, 6);
    const HullVisibility vis = ComputeHullVisibility(q, cams, 80, vo, 2);
    const std::vector<cv::Rect> rects = GlTexture::ObjectImageRects(q, images);
    GlTexture whole, part;
    whole.UploadImages(images);
    part.UploadImages(images, &rects);
    const cv::Mat want = whole.Texture(depth, tile, view, images, {}, &vis);
    const cv::Mat got = part.Texture(depth, tile, view, images, {}, &vis);
    EXPECT_GT(cv::countNonZero(want.reshape(1)), 300) << "hull pixels textured";
    EXPECT_EQ(cv::norm(got, want, cv::NORM_INF), 0.0);
    EXPECT_EQ(part.refetched_images(), 0);
    EXPECT_LT(part.uploaded_bytes(), whole.uploaded_bytes() / 2);
    std::printf("%s: images uploaded %zu of %zu bytes\n", rig.c_str(), part.uploaded_bytes(), whole.uploaded_bytes());
  }
}

TEST_F(Gl, GlBackendRendersAFramesetAsTheCpuBackend) {
  // The backend's whole frameset path (upload, visibility maps by the march,
  // sweep, texture) against the CPU backend's.
  const TexturedSphere t(Distortion{});
  const auto& [views, q, images, view, depths, cams, vo] = t;
  const auto gpu = MakeSweepBackend("gl", 1, 6), cpu = MakeSweepBackend("cpu", 1, 6);
  for (SweepBackend* b : {gpu.get(), cpu.get()}) {
    b->BeginFrameset(q, images);
    b->ComputeVisibility(q, cams, 80, vo);
  }
  const HullVisibility vg = gpu->KeptVisibility(), vc = cpu->KeptVisibility();
  ASSERT_EQ(vg.depth.size(), 4u);
  for (size_t k = 0; k < 4; ++k)
    ExpectMarchMatches(vg.depth[k], vc.depth[k], 0, 0.03, "visibility map " + std::to_string(k), 100);
  const cv::Rect tile = TileRect(1, 2, 200, 150);
  const cv::Mat dg = gpu->Sweep(q, view, depths, tile), dc = cpu->Sweep(q, view, depths, tile);
  ExpectMarchMatches(dg, dc, 0, 0.02, "tile");
  // Each backend's texture with its own kept maps (the GL one's never left the GPU).
  ExpectColoursMatch(gpu->Texture(dc, tile, view, images, true), cpu->Texture(dc, tile, view, images, true), 0.02,
                     "texture");
  ExpectColoursMatch(gpu->Texture(dc, tile, view, images, false), cpu->Texture(dc, tile, view, images, false), 0.02,
                     "texture without visibility");
  // The tile the march returned is textured from its copy on the GPU: the same
  // colours as from a copy uploaded again (a clone is another Mat).
  const cv::Mat from_gpu = gpu->Texture(dg, tile, view, images, true);
  const cv::Mat uploaded = gpu->Texture(dg.clone(), tile, view, images, true);
  EXPECT_EQ(cv::norm(from_gpu, uploaded, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::countNonZero(from_gpu.reshape(1)), 100) << "hull pixels textured";
  // SweepTextured (both passes queued, one read-back on GL) gives exactly the two
  // calls' depth and colour, with and without the visibility test, on both
  // backends; and the GL one's equals the CPU's as the two calls do.
  for (const bool vis : {true, false}) {
    SCOPED_TRACE(vis ? "with visibility" : "without visibility");
    const cv::Mat two_calls = gpu->Texture(gpu->Sweep(q, view, depths, tile), tile, view, images, vis);
    const TexturedTile g = gpu->SweepTextured(q, view, depths, tile, images, vis);
    EXPECT_EQ(cv::norm(g.depth != dg, cv::NORM_INF), 0.0) << "the same depths, +inf included";
    EXPECT_EQ(cv::norm(g.colour, two_calls, cv::NORM_INF), 0.0);
    const TexturedTile c = cpu->SweepTextured(q, view, depths, tile, images, vis);
    EXPECT_EQ(cv::norm(c.depth != dc, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(c.colour, cpu->Texture(dc, tile, view, images, vis), cv::NORM_INF), 0.0);
    ExpectColoursMatch(g.colour, c.colour, 0.02, "SweepTextured, GL against CPU");
  }
  // A tile off the hull: nothing dispatched, every depth kNoDepth, black.
  const Eigen::Vector3d eye = view.world_from_eye.translation;
  const NovelView away = NovelView::FromFov(200, 150, 0.3,
                                            LookAt(eye, eye - view.world_from_eye.rotation.col(2),
                                                   -view.world_from_eye.rotation.col(1)));  // facing away
  const TexturedTile off =
      gpu->SweepTextured(q, away, SweepPlaneDepths(q, away, PlaneSweepOptions{}), tile, images, true);
  EXPECT_EQ(cv::countNonZero(off.depth != kNoDepth), 0);
  EXPECT_EQ(cv::countNonZero(off.colour.reshape(1)), 0);
}

TEST_F(Gl, FiveProcessesWithTheGlBackend) {
  // The pipeline with both recon nodes on GL (the ray march, refinement and
  // texturing on the GPU): frames are composited and each recon node reports the
  // GL renderer it used in stats.json.
  const auto out = test::TempDir("e2e_gl");
  // Capture at 5 fps, not the source's 25: render takes the newest frameset, and
  // with llvmpipe's sweeps on a loaded 2-core machine it composited 2 of 20.
  std::ofstream(out / "capture_5fps.yaml")
      << test::LocalDescriptionWith(test::kCaptureWaitArg, "--fps, \"5\", " + test::kCaptureWaitArg);
  test::Process launch({test::BinDir() + "/hullpipe_launch", "--synthetic", "--frames", "20", "--width", "160",
                        "--height", "120", "--backend", "gl", "--out", out.string(), "--description",
                        (out / "capture_5fps.yaml").string(), "--domain", std::to_string(test::UniqueDomain())},
                       (out / "launch.log").string());
  ASSERT_EQ(launch.Wait(240), 0) << test::ReadFile((out / "launch.log").string());
  const auto j = nlohmann::json::parse(test::ReadFile((out / "stats.json").string()));
  EXPECT_GE(j["frames_composited"].get<int>(), 3);
  EXPECT_GT(j["hull_pixel_fraction_mean"].get<double>(), 0.01);
  for (const char* node : {"recon0", "recon1"}) {
    const std::string backend = j["nodes"][node].value("backend", "");
    EXPECT_NE(backend.find("gl march"), std::string::npos) << node << ": " << backend;
    EXPECT_NE(backend.find(ctx_->renderer()), std::string::npos) << node << ": " << backend;
  }
}

// sim_node's CAD models with the GL triangle query (MakeTriangleQuery "gl")
// against the CPU query: over frames of the synthetic figure the same parts
// collide and their collision points agree as GL's and the CPU's triangle
// queries do (TriangleQueryMatchesCpu: edge pixels, within 3%). "cpu" and, on
// a software renderer, "auto" give the CPU query.
TEST_F(Gl, CadModelsCollideTheSameWithTheGlTriangleQuery) {
  std::string said;
  EXPECT_FALSE(MakeTriangleQuery("cpu", {}, &said));
  EXPECT_NE(said.find("cpu"), std::string::npos);
  if (ctx_->IsSoftware()) {
    EXPECT_FALSE(MakeTriangleQuery("auto", {}, &said));
    EXPECT_NE(said.find("software"), std::string::npos) << said;
  }
  EXPECT_THROW(MakeTriangleQuery("vulkan"), std::invalid_argument);
  // What auto does on a hardware GPU, here on whatever GL this machine has:
  // both queries timed, and the choice said with both fits; a function it
  // returns answers as the GL or the CPU query does.
  std::optional<EglContext> measure_ctx = EglContext::TryCreate();
  ASSERT_TRUE(measure_ctx);
  std::string measured;
  const TriangleQueryFunction chosen = MeasuredTriangleQuery(std::move(*measure_ctx), 1, &measured);
  EXPECT_NE(measured.find("measured GL"), std::string::npos) << measured;
  EXPECT_NE(measured.find("CPU (1 thread)"), std::string::npos) << measured;
  EXPECT_EQ(bool(chosen), measured.find("gl triangle query") == 0) << measured;
  EXPECT_THROW(MeasuredTriangleQuery(*EglContext::TryCreate(), 0), std::invalid_argument);
  const TriangleQueryFunction gl_query = MakeTriangleQuery("gl", {}, &said);
  ASSERT_TRUE(gl_query) << said;
  EXPECT_NE(said.find("gl triangle query"), std::string::npos) << said;

  const auto dir = test::TempDir("gl_models");
  {
    // Two boxes (OBJ, metres) where the figure's right forearm waves, one far.
    std::ofstream o(dir / "parts.obj");
    int base = 0;
    for (const auto& [name, c, h] : {std::tuple{"crossed", Eigen::Vector3d(0.55, 0.0, -1.5), 0.1},
                                     std::tuple{"beside", Eigen::Vector3d(0.75, 0.0, -1.6), 0.06},
                                     std::tuple{"far", Eigen::Vector3d(-1.0, 1.0, -0.5), 0.05}}) {
      test::WriteObjCube(o, name, c, h, base);
      base += 8;
    }
  }
  std::ofstream(dir / "scene.yaml") << "gravity: [0, 0, 9.81]\nballs: []\nmodels:\n  - {file: parts.obj, units: m, "
                                       "up: -z, max_pixel_size: 0.004}\n";
  SceneConfig cpu_cfg = LoadSceneConfig((dir / "scene.yaml").string());
  SceneConfig gl_cfg = cpu_cfg;
  ModelsConfig m = *gl_cfg.Find<ModelsConfig>();
  m.query = gl_query;
  gl_cfg.Set(std::move(m));
  VirtualScene cpu(cpu_cfg), gl(gl_cfg);
  const auto cams = RingCameras(4, 3.0, 1.8, Eigen::Vector3d(0.2, 0, -1.0), 320, 240, 1.0);
  size_t cpu_points = 0, gl_points = 0;
  int colliding_frames = 0;
  for (int f = 0; f < 8; ++f) {
    const VolumeQuery q = test::HullOf(AnimatedFigure(0.5 * f), cams);
    cpu.Step(0.5, &q);
    gl.Step(0.5, &q);
    const ElementOutput a = cpu.Output(0.5 * f, uint64_t(f + 1)), b = gl.Output(0.5 * f, uint64_t(f + 1));
    ASSERT_EQ(a.model_states.size(), 1u);
    ASSERT_EQ(b.model_states.size(), 1u);
    for (size_t k = 0; k < 3; ++k)
      EXPECT_EQ(int(a.model_states[0].parts[k].contact), int(b.model_states[0].parts[k].contact))
          << "frame " << f << " part " << k;
    ASSERT_EQ(a.reports.size(), b.reports.size()) << "frame " << f;
    for (size_t r = 0; r < a.reports.size(); ++r) {
      EXPECT_EQ(a.reports[r].object_id, b.reports[r].object_id);
      cpu_points += a.reports[r].collision_points.size();
      gl_points += b.reports[r].collision_points.size();
    }
    colliding_frames += !a.reports.empty();
  }
  EXPECT_GE(colliding_frames, 3) << "the figure must touch a part for the comparison to mean anything";
  EXPECT_GT(cpu_points, 50u);
  EXPECT_NEAR(double(gl_points), double(cpu_points), 0.03 * double(cpu_points));
}

}  // namespace
}  // namespace hullpipe::gl
