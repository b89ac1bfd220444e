// Collision detection and response (paper §4) on the hard cases, each
// against exact ground truth: the exact contact region of a triangle with the hull
// (ExactContactSegments), the exact first hull point (ray–hull intervals) and the
// analytic hull normal. The tunnelling case is BallSimulation.AFastBallDoesNot-
// TunnelThroughAThinHull in volume_query_test.cc.
#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "hullpipe/collision/collision.h"
#include "hullpipe/collision/collision_response.h"
#include "hullpipe/collision/contact_region.h"
#include "hullpipe/collision/hull_surface.h"
#include "hullpipe/geometry/mesh.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

// The test sphere of the shared fixtures (SphereViews, SphereHull, SphereSideView).
using test::kSphereCentre;
using test::kSphereRadius;

TriangleViewport Frame(const Triangle& t) { return MakeTriangleViewport(t.a, t.b, t.c, {}); }

// The collision-point error of one triangle's query against its exact region
// (lines a 50th of a pixel diagonal apart), and the pixel diagonal of its viewport.
struct Checked {
  TriangleQueryResult r;
  std::vector<ContactSegment> region;
  ContactError error;
  double pixel_diag = 0;
};
Checked Check(const VolumeQuery& q, const Triangle& t, const TriangleQueryOptions& o = {}) {
  Checked c;
  c.r = QueryTriangleCpu(q, t.a, t.b, t.c, o);
  const TriangleViewport vp = MakeTriangleViewport(t.a, t.b, t.c, o);
  c.pixel_diag = std::hypot(vp.u_step.norm(), vp.v_step.norm());
  c.region = ExactContactSegments(q, Frame(t), c.pixel_diag / 50);
  c.error = CollisionPointError(c.r.collision_points, c.region, c.pixel_diag / 50);
  // Every collision point is a point of the hull, whatever the case.
  for (const auto& p : c.r.collision_points) EXPECT_TRUE(q.Inside(p));
  return c;
}

class SphereCollision : public ::testing::Test {
 protected:
  SphereCollision() : q_(test::SphereViews(4, 640, 480, kSphereCentre, kSphereRadius), test::BigBox()) {}
  VolumeQuery q_;
};

TEST_F(SphereCollision, ExactRegionAgreesWithDensePointQueries) {
  // A triangle cutting the hull: every dense sample inside the hull lies within
  // one line spacing (the reference samples across its lines) of the region.
  const Triangle t{kSphereCentre + Eigen::Vector3d(0.25, -0.05, 0), kSphereCentre + Eigen::Vector3d(0.36, -0.05, 0.02),
                   kSphereCentre + Eigen::Vector3d(0.28, 0.06, -0.03)};
  const auto region = ExactContactSegments(q_, Frame(t), 1e-4);
  ASSERT_FALSE(region.empty());
  std::vector<Eigen::Vector3d> inside;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 4000; ++i) {
    double a = u(rng), b = u(rng);
    if (a + b > 1) a = 1 - a, b = 1 - b;
    const Eigen::Vector3d p = t.a + a * (t.b - t.a) + b * (t.c - t.a);
    if (q_.Inside(p)) inside.push_back(p);
  }
  ASSERT_GT(inside.size(), 100u);
  const ContactError e = CollisionPointError(inside, region, 1e-5);
  EXPECT_LT(e.points_to_region, 1e-4 + 1e-9) << "a dense sample farther than a line spacing from the region";
  for (const auto& s : region) {
    EXPECT_TRUE(q_.Inside(0.5 * (s.p + s.q)));
  }
}

TEST(ContactError, GridOfPointsAgainstASquare) {
  // Points at the centres of a 10x10 grid of 1 mm cells covering a 1 cm square:
  // every point of the square is within half a cell diagonal (0.707 mm) of one.
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) pts.push_back({(i + 0.5) * 1e-3, (j + 0.5) * 1e-3, 0});
  std::vector<ContactSegment> square;
  for (int k = 0; k <= 100; ++k) square.push_back({{0, k * 1e-4, 0}, {0.01, k * 1e-4, 0}});
  const ContactError e = CollisionPointError(pts, square, 1e-5);
  EXPECT_NEAR(e.region_to_points, std::sqrt(0.5) * 1e-3, 2e-5);
  EXPECT_NEAR(e.points_to_region, 0.0, 1e-4 / 2 + 1e-12);
  EXPECT_TRUE(std::isinf(CollisionPointError({}, square, 1e-4).region_to_points));
  EXPECT_TRUE(std::isinf(CollisionPointError(pts, {}, 1e-4).points_to_region));
  EXPECT_EQ(CollisionPointError({}, {}, 1e-4).hausdorff(), 0.0);
}

TEST_F(SphereCollision, TriangleWhollyInsideIsOneCollisionPointPerPixel) {
  const Triangle t{kSphereCentre, kSphereCentre + Eigen::Vector3d(0.02, 0, 0),
                   kSphereCentre + Eigen::Vector3d(0, 0.02, 0.005)};
  const Checked c = Check(q_, t);
  EXPECT_EQ(int(c.r.collision_points.size()), c.r.pixels_tested);
  // The region is the whole triangle; pixel centres cover it to half a diagonal,
  // more along the edges where the first centre is up to a pixel in.
  EXPECT_LE(c.error.hausdorff(), c.pixel_diag + 1e-6);
}

TEST_F(SphereCollision, SliverTriangleOfAspect1000) {
  // 10 cm long, 0.1 mm wide, crossing the hull's surface: its viewport is one
  // pixel high; the collision points still follow the exact contact to a pixel.
  const Eigen::Vector3d a = kSphereCentre + Eigen::Vector3d(0.22, 0.01, 0.0);
  const Triangle t{a, a + Eigen::Vector3d(0.1, 0, 0), a + Eigen::Vector3d(0.05, 1e-4, 0)};
  const Checked c = Check(q_, t);
  ASSERT_FALSE(c.region.empty());
  ASSERT_FALSE(c.r.collision_points.empty());
  EXPECT_LE(c.error.hausdorff(), c.pixel_diag + 1e-6);
}

TEST_F(SphereCollision, TriangleSmallerThanAPixelIsStillQueried) {
  // 0.5 mm across with 2 mm pixels: a 1x1 viewport, sampled at the middle of the
  // triangle's chord through the pixel's centre column: inside the hull one
  // collision point, on the triangle; outside none.
  const Eigen::Vector3d d1(5e-4, 0, 0), d2(0, 5e-4, 0);
  const auto in = QueryTriangleCpu(q_, kSphereCentre, kSphereCentre + d1, kSphereCentre + d2);
  EXPECT_EQ(in.pixels_tested, 1);
  ASSERT_EQ(in.collision_points.size(), 1u);
  const Eigen::Vector3d rel = in.collision_points[0] - kSphereCentre;
  EXPECT_NEAR(rel.z(), 0, 1e-12);
  EXPECT_GE(rel.x(), -1e-12);
  EXPECT_GE(rel.y(), -1e-12);
  EXPECT_LE(rel.x() + rel.y(), 5e-4 + 1e-12);
  const Eigen::Vector3d far = kSphereCentre + Eigen::Vector3d(1, 0, 0);
  EXPECT_TRUE(QueryTriangleCpu(q_, far, far + d1, far + d2).collision_points.empty());
}

TEST_F(SphereCollision, TriangleLargerThanTheHull) {
  // 3 m across, through the sphere: the viewport is capped (64 px, ~5 cm pixels)
  // and still finds the hull's cross-section to a pixel.
  const Triangle t{kSphereCentre + Eigen::Vector3d(-1.5, -1, 0.01), kSphereCentre + Eigen::Vector3d(1.5, -1, 0.01),
                   kSphereCentre + Eigen::Vector3d(0, 2, 0.01)};
  const Checked c = Check(q_, t);
  ASSERT_FALSE(c.r.collision_points.empty());
  EXPECT_GT(c.pixel_diag, 0.03);
  EXPECT_LE(c.error.hausdorff(), c.pixel_diag);
  // A virtual box wholly containing the hull touches it nowhere: detection is of
  // surfaces (§4.1), so an object swallowing the hull reports no collision.
  Rigid3d pose;
  pose.translation = kSphereCentre;
  const CollisionResult around = DetectCollisions(q_, TriangleMesh::Box({1, 1, 1}, 0.1).Transformed(pose));
  EXPECT_TRUE(around.box_overlap);
  EXPECT_FALSE(around.colliding());
}

TEST_F(SphereCollision, ZeroLengthRecoveryVectorFallsBack) {
  // CP_obj == RP_obj: V_rec has no direction; both methods take it from the hull
  // box's centre toward RP_obj (out of the hull) and say so.
  const Eigen::Vector3d cp = kSphereCentre + Eigen::Vector3d(0.27, 0.02, 0);
  for (int m = 0; m < 2; ++m) {
    const auto r = m == 0 ? ComputeResponse(q_, {cp}, cp) : ComputeResponsePaper(q_, {cp}, cp);
    ASSERT_TRUE(r.has_value()) << m;
    SCOPED_TRACE(m == 0 ? "exact" : "paper");
    EXPECT_TRUE(r->v_rec_fallback);
    EXPECT_NEAR(r->v_rec.norm(), 1.0, 1e-12);
    EXPECT_GT(r->v_rec.dot(cp - q_.hull_box().Center()), 0);
    EXPECT_FALSE(q_.Inside(r->cp_hull + 2e-3 * r->v_rec)) << "CP_hull is where the hull ends along V_rec";
  }
}

TEST_F(SphereCollision, RefinedFarthestPointIsExactToALineSpacing) {
  // A box (2 cm triangles) pushed 2 cm into the hull at 10x10 viewports (~2.8 mm
  // pixels): the refined CP_obj is as far from RP_obj as the exact region's
  // farthest point (lines 0.01 mm apart) to within a refinement line spacing.
  Rigid3d pose;
  pose.rotation = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  pose.translation = kSphereCentre + Eigen::Vector3d(kSphereRadius + 0.01, 0.02, -0.01);
  const TriangleMesh mesh = TriangleMesh::Box({0.06, 0.04, 0.03}, 0.02).Transformed(pose);
  const TriangleQueryOptions o{0.002, 10, 64};
  CollisionResult hit = DetectCollisions(q_, mesh, o);
  ASSERT_TRUE(hit.colliding());
  ASSERT_EQ(hit.point_triangles.size(), hit.collision_points.size());
  double coarse = 0, exact = 0;
  for (const auto& p : hit.collision_points) coarse = std::max(coarse, (p - pose.translation).norm());
  for (const auto& t : mesh.triangles) {
    const Triangle tri{mesh.vertices[size_t(t[0])], mesh.vertices[size_t(t[1])], mesh.vertices[size_t(t[2])]};
    for (const auto& s : ExactContactSegments(q_, Frame(tri), 1e-5))
      exact = std::max({exact, (s.p - pose.translation).norm(), (s.q - pose.translation).norm()});
  }
  const auto refined = RefineFarthestCollisionPoint(q_, mesh, pose.translation, o, &hit);
  ASSERT_TRUE(refined.has_value());
  EXPECT_TRUE(q_.Inside(*refined));
  const double got = (*refined - pose.translation).norm();
  const double line = 0.02 / 10 / 16;  // pixel / lines_per_pixel
  EXPECT_GT(got, coarse);
  EXPECT_NEAR(got, exact, line);
  EXPECT_LT(exact - coarse, 3e-3) << "the coarse CP_obj is within a pixel";
  EXPECT_EQ(hit.collision_points.back(), *refined);
}

TEST(SmoothHull, NormalOfASpheresHullIsTheTangentConesNormal) {
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Sphere(kSphereCentre, kSphereRadius));
  const Eigen::Vector3d C(3, 0.5, -1.5);
  // A point on the cone from C tangent to the sphere.
  const Eigen::Vector3d a = (kSphereCentre - C).normalized();
  const Eigen::Vector3d perp = a.unitOrthogonal();
  const double dist = (kSphereCentre - C).norm(), half = std::asin(kSphereRadius / dist);
  const Eigen::Vector3d gen = (std::cos(half) * a + std::sin(half) * perp).normalized();
  const Eigen::Vector3d X = C + 2.8 * gen;
  const Eigen::Vector3d truth = -(a - a.dot(gen) * gen).normalized();
  bool edge = true;
  const Eigen::Vector3d n = SmoothHullNormal(scene, {C, Eigen::Vector3d(-3, 0, -1)}, X, 5e-4, &edge);
  EXPECT_LT(std::acos(std::clamp(n.dot(truth), -1.0, 1.0)), 1e-4);
  EXPECT_FALSE(edge);
}

// Hulls with planar faces: each camera's map is object on one side of a pixel
// column, so each cone face is the plane through the camera's centre and that
// column's back-projected line.
class PlaneHull : public ::testing::Test {
 protected:
  explicit PlaneHull(size_t faces = 1) {
    const Eigen::Vector3d target(0, 0, -1);
    cams_ = RingCameras(3, 2.0, 1.0, target, 320, 240, 1.0);
    std::vector<CameraMap> views;
    for (size_t i = 0; i < cams_.size(); ++i) {
      cv::Mat m(240, 320, CV_8UC1, cv::Scalar(255));
      if (i < faces) m.colRange(kColumn, 320).setTo(0);  // object left of u = 160
      views.push_back({cams_[i], m});
    }
    q_.emplace(views, test::BigBox(), VolumeQueryOptions{OutOfView::kOutside, 2});
  }
  // Outward unit normal (world) of camera i's face u = kColumn.
  Eigen::Vector3d FaceNormal(size_t i) const {
    const Camera& c = cams_[i];
    const Eigen::Vector3d n_cam(c.fx, 0, -(kColumn - c.cx));
    return (c.cam_from_world.rotation.transpose() * n_cam).normalized();
  }
  // A point of camera i's face at depth z in its frame, row v.
  Eigen::Vector3d OnFace(size_t i, double z, double v) const {
    const Camera& c = cams_[i];
    const Eigen::Vector3d xc((kColumn - c.cx) / c.fx * z, (v - c.cy) / c.fy * z, z);
    return c.cam_from_world.Inverse() * xc;
  }
  static constexpr int kColumn = 160;
  std::vector<Camera> cams_;
  std::optional<VolumeQuery> q_;
};

// Cameras 0 and 1 each give a face: the hull has an edge where they meet.
class WedgeHull : public PlaneHull {
 protected:
  WedgeHull() : PlaneHull(2) {}
};

TEST_F(PlaneHull, TriangleCoplanarWithAHullFace) {
  // A triangle in camera 0's face plane: its points project onto the column
  // boundary, where the map's rounding decides. Moved 1 µm inward it lies wholly
  // inside the hull (a collision point per pixel), 1 µm outward wholly outside;
  // on the plane itself the answer is each pixel's rounding, the same every time,
  // and every collision point is inside the hull.
  const Eigen::Vector3d n = FaceNormal(0);
  const Eigen::Vector3d a = OnFace(0, 2.0, 110), b = OnFace(0, 2.02, 118), c = OnFace(0, 1.99, 125);
  ASSERT_NEAR(n.dot(b - a), 0, 1e-12);
  for (const double off : {-1e-6, 1e-6}) {
    const Eigen::Vector3d d = off * n;
    const auto r = QueryTriangleCpu(*q_, a + d, b + d, c + d);
    if (off < 0) {
      EXPECT_EQ(int(r.collision_points.size()), r.pixels_tested) << "1 um inside";
    } else {
      EXPECT_TRUE(r.collision_points.empty()) << "1 um outside";
    }
  }
  const auto on1 = QueryTriangleCpu(*q_, a, b, c), on2 = QueryTriangleCpu(*q_, a, b, c);
  EXPECT_EQ(on1.collision_points, on2.collision_points);
  for (const auto& p : on1.collision_points) EXPECT_TRUE(q_->Inside(p));
  // The exact method's normal on the face is the face's normal.
  const Eigen::Vector3d inside = a - 0.01 * n;
  const auto hn = HullSurfaceNormal(*q_, *FirstHullPointAlong(*q_, a + 0.05 * n, -n, 0.1));
  ASSERT_TRUE(hn.has_value());
  EXPECT_GT(hn->normal.dot(n), std::cos(2.0 * M_PI / 180));
  EXPECT_TRUE(q_->Inside(inside));
}

TEST_F(WedgeHull, NormalOnAHullEdgeIsTheDocumentedBlend) {
  // Where the faces of cameras 0 and 1 meet, the normal is undefined: the exact
  // method flags the edge and returns the normalized sum of the two faces'
  // normals, which points out of both.
  const Eigen::Vector3d n0 = FaceNormal(0), n1 = FaceNormal(1);
  // A point on both planes: solve for the intersection line near the target.
  Eigen::Matrix<double, 2, 3> A;
  A.row(0) = n0.transpose(), A.row(1) = n1.transpose();
  const Eigen::Vector2d rhs(n0.dot(cams_[0].Center()), n1.dot(cams_[1].Center()));
  const Eigen::Vector3d dir = n0.cross(n1).normalized();
  Eigen::Matrix3d M;
  M.row(0) = n0.transpose(), M.row(1) = n1.transpose(), M.row(2) = dir.transpose();
  const Eigen::Vector3d on_edge =
      M.inverse() * Eigen::Vector3d(rhs.x(), rhs.y(), dir.dot(Eigen::Vector3d(0, 0, -1)));
  ASSERT_NEAR((A * on_edge - rhs).norm(), 0, 1e-9);
  const Eigen::Vector3d out = (n0 + n1).normalized();
  const auto cp = FirstHullPointAlong(*q_, on_edge + 0.05 * out, -out, 0.1);
  ASSERT_TRUE(cp.has_value());
  const auto hn = HullSurfaceNormal(*q_, *cp);
  ASSERT_TRUE(hn.has_value());
  EXPECT_TRUE(hn->edge);
  EXPECT_GT(hn->normal.dot(n0), 0);
  EXPECT_GT(hn->normal.dot(n1), 0);
  EXPECT_GT(hn->normal.dot(out), std::cos(10.0 * M_PI / 180));
}

TEST(ConcaveHull, TriangleAcrossATorusHoleFollowsTheExactRegion) {
  // A torus seen by 6 dome cameras: its hull is concave (cameras see through the
  // hole). A triangle spanning the hole meets the hull in two separate parts; the
  // collision points cover both, to a pixel, and the first hull point along a
  // line through the hole is the near tube's, not the far one.
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Torus({0, 0, -1}, 0.25, 0.08));
  std::vector<CameraMap> views;
  for (const auto& c : DomeCameras(6, 3.0, {0, 0, -1}, 640, 480, 0.9)) views.push_back({c, RenderExactMap(c, scene)});
  const VolumeQuery q(views, test::BigBox());
  const Triangle t{{-0.4, -0.02, -1.0}, {0.4, -0.02, -1.0}, {0.0, 0.03, -1.0}};
  ASSERT_FALSE(q.Inside({0, 0, -1.0})) << "the hole is seen through";
  const Checked c = Check(q, t, {0.002, 0, 64});
  ASSERT_FALSE(c.r.collision_points.empty());
  bool left = false, right = false;
  for (const auto& p : c.r.collision_points) (p.x() < 0 ? left : right) = true;
  EXPECT_TRUE(left && right) << "both tubes";
  EXPECT_LE(c.error.hausdorff(), c.pixel_diag + 1e-6);
  const auto first = FirstHullPointAlong(q, {-0.5, 0, -1.0}, {1, 0, 0}, 1.0);
  ASSERT_TRUE(first.has_value());
  EXPECT_LT(first->x(), -0.3) << "the near tube's outer side";
}

TEST(PartialViews, TriangleOutsideSomeCamerasViews) {
  // Camera 0 sees only part of the triangle. With the default out-of-view rule
  // (a camera that cannot see does not vote) the rest is still decided by the
  // others; with the paper's rule it is outside. Both agree with their exact
  // regions to a pixel, and the collision points are each rule's Inside.
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Sphere(kSphereCentre, kSphereRadius));
  auto cams = RingCameras(4, 3.0, 1.8, kSphereCentre, 640, 480, 1.0);
  // Narrow camera 0's view to ~5 degrees: most of the sphere is outside it.
  cams[0].fx *= 12, cams[0].fy *= 12;
  std::vector<CameraMap> views;
  for (const auto& c : cams) views.push_back({c, RenderExactMap(c, scene)});
  const Triangle t{kSphereCentre + Eigen::Vector3d(-0.25, -0.1, 0), kSphereCentre + Eigen::Vector3d(0.25, -0.1, 0),
                   kSphereCentre + Eigen::Vector3d(0, 0.25, 0)};
  size_t unknown_points = 0, outside_points = 0;
  for (const OutOfView rule : {OutOfView::kUnknown, OutOfView::kOutside}) {
    const VolumeQuery q(views, test::BigBox(), {rule, 2});
    const Checked c = Check(q, t, {0.004, 0, 64});
    EXPECT_LE(c.error.hausdorff(), c.pixel_diag + 1e-6);
    (rule == OutOfView::kUnknown ? unknown_points : outside_points) = c.r.collision_points.size();
  }
  // The triangle lies inside the sphere: by the default rule it collides at every
  // sample; the paper's rule clips off what camera 0 does not see.
  EXPECT_EQ(unknown_points, 2048u);
  EXPECT_LT(outside_points, unknown_points - 100) << "the paper's rule clips the hull to camera 0's narrow view";
  EXPECT_GT(outside_points, 0u);
}

TEST(PointQueries, ParticlesAreQueriedAsPoints) {
  const VolumeQuery q(test::SphereViews(4, 320, 240, kSphereCentre, kSphereRadius), test::BigBox());
  const std::vector<Eigen::Vector3d> pts = {kSphereCentre, kSphereCentre + Eigen::Vector3d(2, 0, 0),
                                            kSphereCentre + Eigen::Vector3d(0.29, 0, 0) * 0.5};
  const auto in = QueryPoints(q, pts);
  ASSERT_EQ(in.size(), 3u);
  for (size_t k = 0; k < pts.size(); ++k) EXPECT_EQ(bool(in[k]), q.Inside(pts[k])) << k;
  EXPECT_TRUE(in[0]);
  EXPECT_FALSE(in[1]);
}

TEST(Collision, BoxTestSkipsDistantMeshes) {
  const VolumeQuery q(test::SphereViews(4, 160, 120, kSphereCentre, kSphereRadius), test::BigBox());
  Rigid3d far;
  far.translation = kSphereCentre + Eigen::Vector3d(3, 0, 0);
  const auto r = DetectCollisions(q, TriangleMesh::Icosphere(0.1, 1).Transformed(far));
  EXPECT_FALSE(r.box_overlap);
  EXPECT_EQ(r.triangles_queried, 0);
  Rigid3d touching;
  touching.translation = kSphereCentre + Eigen::Vector3d(kSphereRadius + 0.05, 0, 0);
  const auto t = DetectCollisions(q, TriangleMesh::Icosphere(0.1, 2).Transformed(touching));
  EXPECT_TRUE(t.colliding());
}

}  // namespace
}  // namespace hullpipe
