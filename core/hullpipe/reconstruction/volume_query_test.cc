// Volume query (paper §3.2) and the hull box against exact ground truth: an
// analytic sphere and a capsule seen by ring cameras with exact maps, the box
// against the hull's brute-force box, a map's known object rectangle against a
// scan of the map.
#include "hullpipe/reconstruction/volume_query.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/geometry/rig_world.h"
#include "hullpipe/geometry/rigid3.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

// The test sphere of the shared fixtures (SphereViews, SphereHull, SphereSideView).
using test::kSphereCentre;
using test::kSphereRadius;

using test::SphereHull;

TEST_F(SphereHull, PointsInsideTheSphereAreInside) {
  // The hull contains the sphere; a point deeper than ~2 pixel footprints
  // (3 m * 2 / 277 px = 2.2 cm) inside it projects onto object pixels everywhere.
  for (double x = -1; x <= 1; x += 0.25)
    for (double y = -1; y <= 1; y += 0.25)
      for (double z = -1; z <= 1; z += 0.25) {
        const Eigen::Vector3d p = kSphereCentre + Eigen::Vector3d(x, y, z) * (kSphereRadius - 0.025) / std::sqrt(3.0);
        EXPECT_TRUE(query_.Inside(p)) << p.transpose();
        EXPECT_EQ(query_.Count(p), 4);
      }
}

TEST_F(SphereHull, PointsFarOutsideAreOutside) {
  EXPECT_FALSE(query_.Inside(kSphereCentre + Eigen::Vector3d(1, 0, 0)));
  EXPECT_FALSE(query_.Inside(kSphereCentre + Eigen::Vector3d(0, 0, 0.6)));
  // Behind every camera: outside, never mirrored onto object pixels.
  for (const auto& v : query_.views()) {
    const Eigen::Vector3d c = v.camera.Center();
    const Eigen::Vector3d mirror = c - (kSphereCentre - c);
    EXPECT_FALSE(query_.Inside(mirror));
  }
}

TEST_F(SphereHull, HullBoxContainsTheSphereAndIsTight) {
  const Aabb& box = query_.hull_box();
  ASSERT_FALSE(box.empty());
  EXPECT_TRUE((box.min.array() <= (kSphereCentre.array() - kSphereRadius)).all()) << box.min.transpose();
  EXPECT_TRUE((box.max.array() >= (kSphereCentre.array() + kSphereRadius)).all()) << box.max.transpose();
  // Four cameras carve the pyramids' intersection to well under twice the sphere.
  EXPECT_LT((box.max - box.min).maxCoeff(), 4 * kSphereRadius);
}

// A standing capsule in a ring of 6 cameras (three opposite pairs, as labs set
// them up), under both policies, with and without lens distortion; and in a
// dome of 12 distorted cameras whose workspace reaches past what most of them
// see (as the published dome's does), where a cell's search asks only the
// cameras its parent left undecided. The hull's box must hold every hull point
// (conservative) and lie within two leaves of the octree search (leaf: at most
// the workspace's largest side / 64 and 2 cm; a leaf's projected rectangle
// reaches past its outline by up to about another) plus the 2-cm sampling step
// of the hull's own box found here by brute force. The pyramid boxes it starts
// from are metres wider under kUnknown (each pair of cameras meets along the
// line between them): a box not tightened fails this.
TEST(HullBox, TightToTheHullsOwnBoxOnARingAndConservative) {
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Capsule({0.3, -0.2, -0.2}, {0.3, -0.2, -1.5}, 0.15));
  struct Rig {
    std::string name;
    std::vector<Camera> cams;
    Aabb workspace;
  };
  std::vector<Rig> rigs;
  for (const double k1 : {0.0, -0.3}) {
    Distortion d{};
    d[0] = k1;
    const auto cams = RingCameras(6, 3.0, 1.6, {0.3, -0.2, -0.9}, 240, 180, 1.1, d);
    rigs.push_back({k1 ? "ring, distorted" : "ring, pinhole", cams, CommonViewWorkspace(cams)});
  }
  {
    Distortion d{};
    d[0] = -0.04, d[1] = 0.06;
    const auto cams = DomeCameras(12, 3.0, {0.3, -0.2, -0.9}, 200, 150, 0.9, d);
    const Eigen::Vector3d c(0.3, -0.2, -0.9);
    const Eigen::Vector3d half(1.0, 1.0, 0.9);
    rigs.push_back({"dome, distorted", cams, Aabb{c - half, c + half}});
  }
  for (const Rig& rig : rigs) {
    const Aabb& workspace = rig.workspace;
    ASSERT_FALSE(workspace.empty());
    for (const OutOfView policy : {OutOfView::kUnknown, OutOfView::kOutside}) {
      SCOPED_TRACE(rig.name + (policy == OutOfView::kUnknown ? ", kUnknown" : ", kOutside"));
      VolumeQueryOptions o;
      o.out_of_view = policy;
      const VolumeQuery q(test::ExactViews(rig.cams, scene), workspace, o);
      const Aabb& box = q.hull_box();
      ASSERT_FALSE(box.empty());
      // The hull's own box by brute force: every 2 cm of the workspace.
      Aabb sampled;
      const double step = 0.02;
      for (double x = workspace.min.x(); x <= workspace.max.x(); x += step)
        for (double y = workspace.min.y(); y <= workspace.max.y(); y += step)
          for (double z = workspace.min.z(); z <= workspace.max.z(); z += step) {
            const Eigen::Vector3d p(x, y, z);
            if (!q.Inside(p)) continue;
            sampled.Extend(p);
            ASSERT_TRUE(box.Contains(p)) << p.transpose() << " is inside the hull but not in its box";
          }
      ASSERT_FALSE(sampled.empty());
      const double leaf = std::min((workspace.max - workspace.min).maxCoeff() / 64, 0.02);
      const double slack = 2 * leaf + step + 1e-9;
      EXPECT_LT((sampled.min - box.min).maxCoeff(), slack) << box.min.transpose() << " vs " << sampled.min.transpose();
      EXPECT_LT((box.max - sampled.max).maxCoeff(), slack) << box.max.transpose() << " vs " << sampled.max.transpose();
    }
  }
}

// A ring's hull box in the box around its cameras and in what every camera
// sees (CompleteRig's workspace). In front of a camera, a cell cannot be ruled
// out by that camera (it sees the cell at every angle), the camera opposite
// sees it on object pixels (their line runs through the person), and the others
// see it at most in part, at the edge of their views, on background. Those
// cannot see an inside point of the cell (any point they see is vetoed), so
// they do not count towards the two cameras an inside point needs: the cell is
// proven empty, and both boxes are the person's (before that rule the first
// reached out 3 m to the cameras). Conservative: every inside point on a grid
// of the larger box (2 cm across, 20 cm tall) lies in its hull box.
TEST(Workspace, WhatEveryCameraSeesKeepsARingsHullBoxToThePerson) {
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Capsule({0.3, -0.2, -0.2}, {0.3, -0.2, -1.5}, 0.15));
  const auto cams = RingCameras(6, 3.0, 1.6, {0.3, -0.2, -0.9}, 240, 180, 1.1);
  const auto views = test::ExactViews(cams, scene);
  const Aabb ws = DefaultWorkspace(cams);
  const VolumeQuery around(views, ws), common(views, CommonViewWorkspace(cams));
  int inside = 0;
  for (double x = ws.min.x(); x <= ws.max.x(); x += 0.02)
    for (double y = ws.min.y(); y <= ws.max.y(); y += 0.02)
      for (double z = ws.min.z(); z <= ws.max.z(); z += 0.2) {
        const Eigen::Vector3d p(x, y, z);
        if (!around.Inside(p)) continue;
        ++inside;
        ASSERT_TRUE(around.hull_box().Contains(p)) << p.transpose() << " is inside the hull but not in its box";
      }
  EXPECT_GT(inside, 100) << "the grid finds the capsule";
  // The capsule is 0.3 m wide and 1.6 m tall; its hull, seen from three
  // directions, a hexagonal prism up to 0.3 / cos 30° = 0.35 m across; the box
  // within two leaves of that (2 x 2 cm).
  for (const VolumeQuery* q : {&around, &common}) {
    const Eigen::Vector3d size = q->hull_box().max - q->hull_box().min;
    EXPECT_LT(size.head<2>().maxCoeff(), 0.35 + 0.04) << size.transpose();
    EXPECT_LT(size.z(), 1.6 + 0.04) << size.transpose();
  }
  for (double z = -0.1; z >= -1.6; z -= 0.05) EXPECT_TRUE(common.Inside({0.3, -0.2, z})) << z;
}

// A map's object rectangle known from its runs (DecodedMap, the frameset
// assembler) gives the same hull box as scanning the map, distorted or not; a
// wrong rectangle changes the box (the positive control that the rectangle is
// used at all).
TEST(HullBox, AKnownObjectRectangleGivesTheSameBoxAsAScan) {
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Capsule({0.3, -0.2, -0.2}, {0.3, -0.2, -1.5}, 0.15));
  Distortion d{};
  d[0] = -0.2;
  const auto cams = RingCameras(6, 3.0, 1.6, {0.3, -0.2, -0.9}, 240, 180, 1.1, d);
  const Aabb workspace = CommonViewWorkspace(cams);
  std::vector<CameraMap> views = test::ExactViews(cams, scene), known = views, wrong = views;
  for (size_t i = 0; i < views.size(); ++i) {
    known[i].object_rect = cv::boundingRect(views[i].map);
    wrong[i].object_rect = cv::Rect(known[i].object_rect->x, known[i].object_rect->y, 1, 1);
  }
  for (const OutOfView policy : {OutOfView::kUnknown, OutOfView::kOutside}) {
    VolumeQueryOptions o;
    o.out_of_view = policy;
    const Aabb scanned = VolumeQuery(views, workspace, o).hull_box();
    const Aabb given = VolumeQuery(known, workspace, o).hull_box();
    EXPECT_EQ(given.min, scanned.min);
    EXPECT_EQ(given.max, scanned.max);
    const Aabb changed = VolumeQuery(wrong, workspace, o).hull_box();
    EXPECT_FALSE(changed.min == scanned.min && changed.max == scanned.max);
  }
}

// The six face searches on several threads (recon's and sim's --threads),
// sharing their cells' verdicts, give the one-thread box exactly, for both
// out-of-view policies.
TEST(HullBox, TheSameBoxOnOneThreadOrSix) {
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Capsule({0.3, -0.2, -0.2}, {0.3, -0.2, -1.5}, 0.15));
  scene.shapes.push_back(Shape::Sphere({0.6, 0.1, -0.8}, 0.12));
  const auto cams = RingCameras(8, 3.0, 1.6, {0.3, -0.2, -0.9}, 240, 180, 1.1);
  const Aabb workspace = CommonViewWorkspace(cams);
  const std::vector<CameraMap> views = test::ExactViews(cams, scene);
  for (const OutOfView policy : {OutOfView::kUnknown, OutOfView::kOutside}) {
    VolumeQueryOptions o;
    o.out_of_view = policy;
    const Aabb one = VolumeQuery(views, workspace, o).hull_box();
    ASSERT_FALSE(one.empty());
    for (int threads : {2, 6}) {
      o.threads = threads;
      const Aabb many = VolumeQuery(views, workspace, o).hull_box();
      EXPECT_EQ(many.min, one.min) << threads;
      EXPECT_EQ(many.max, one.max) << threads;
    }
  }
}

TEST(HullBox, EmptyMapGivesEmptyBox) {
  auto views = test::SphereViews(3, 64, 48, kSphereCentre, kSphereRadius);
  views[1].map.setTo(0);
  const VolumeQuery q(views, test::BigBox());
  EXPECT_TRUE(q.hull_box().empty());
  EXPECT_FALSE(q.Inside(kSphereCentre));
}

// The sweep skips a near miss's scan when the vetoing camera holds its whole
// bracket on background (SegmentOnBackground); the bracket's points must then
// all be background in VoteFast's float arithmetic, also through a lens whose
// image of the bracket is curved. Random short segments (1 to 6 cm: a bracket
// is two plane spacings) around a figure of thin limbs, seen by pinhole,
// skewed, Utrecht-lensed (test::kUtrechtCam1Lens) and strongly barrelled cameras;
// each segment the camera is said to hold on background is sampled at 257
// points. Positive controls: thousands are said to be on background, hundreds
// of them passing within two pixels of an object pixel (where a bound that
// left out the lens's bending fails).
// The proofs' scene: a sphere and a capsule 1.2 cm thick about the test
// sphere's centre; and their lenses: none, the Utrecht rig's, strongly barrelled.
SyntheticScene ProofScene() {
  const Eigen::Vector3d centre = kSphereCentre;
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Sphere(centre, 0.15));
  scene.shapes.push_back(Shape::Capsule(centre + Eigen::Vector3d(-0.4, 0.3, 0.1),
                                        centre + Eigen::Vector3d(0.4, 0.35, -0.2), 0.012));
  return scene;
}
const Distortion kProofLenses[] = {Distortion{}, test::kUtrechtCam1Lens,
                                   Distortion{-0.5, 0.25, 0.002, -0.003, -0.05}};
// A ring of 4 cameras about it through lens l of kProofLenses (the third skewed).
std::vector<Camera> ProofCameras(size_t l) {
  return test::WithSkew(RingCameras(4, 2.2, 1.4, kSphereCentre, 320, 240, 1.2, kProofLenses[l]), l == 2 ? 0.05 : 0.0);
}

TEST(VolumeQuery, ASegmentOnBackgroundHasNoPointOnAnObjectPixel) {
  const Eigen::Vector3d centre = kSphereCentre;
  SyntheticScene scene = ProofScene();
  scene.shapes.push_back(Shape::Capsule(centre + Eigen::Vector3d(0.1, -0.4, 0.3),
                                        centre + Eigen::Vector3d(-0.2, 0.3, -0.4), 0.03));
  cv::RNG rng(11);
  for (size_t l = 0; l < 3; ++l) {
    const auto cams = ProofCameras(l);
    const VolumeQuery q(test::ExactViews(cams, scene), test::BigBox());
    int said = 0, close = 0;
    for (size_t i = 0; i < cams.size(); ++i) {
      const detail::FastCamera& f = q.fast()[i];
      cv::Mat near_object;  // object pixels grown by two
      cv::dilate(q.views()[i].map, near_object, cv::Mat::ones(5, 5, CV_8UC1));
      for (int k = 0; k < 20000; ++k) {
        const Eigen::Vector3d a =
            centre + Eigen::Vector3d(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5));
        const Eigen::Vector3d dir = Eigen::Vector3d(rng.gaussian(1), rng.gaussian(1), rng.gaussian(1)).normalized();
        const Eigen::Vector3d b = a + rng.uniform(0.01, 0.06) * dir;
        const Eigen::Vector3f ac = (cams[i].cam_from_world * a).cast<float>();
        const Eigen::Vector3f bc = (cams[i].cam_from_world * b).cast<float>();
        if (!q.SegmentOnBackground(i, ac, bc)) continue;
        ++said;
        bool passes_close = false;
        for (int j = 0; j <= 256; ++j) {
          const float t = float(j) / 256.0f;
          const Eigen::Vector3f X = ac + t * (bc - ac);
          ASSERT_EQ(VolumeQuery::VoteFast(f, X.x(), X.y(), X.z()), Vote::kBackground)
              << "lens " << l << ", camera " << i << ", segment " << ac.transpose() << " -> " << bc.transpose();
          const auto uv = cams[i].Project(cams[i].cam_from_world.Inverse() * X.cast<double>());
          if (uv && cams[i].InImage(*uv) && near_object.at<uint8_t>(int(uv->y()), int(uv->x())) != 0)
            passes_close = true;
        }
        close += passes_close;
      }
    }
    EXPECT_GT(said, 5000) << "lens " << l;
    EXPECT_GT(close, 200) << "lens " << l;
  }
}

// A piece of a view's frustum, a bundle of a block's corner rays between two
// depths (as the sweep's bounds test it): a camera CountWholeBackground
// counts puts every point of the piece, in the sweep's float arithmetic, on
// background.
TEST(VolumeQuery, AFrustumPieceProvenHasNoPointOnAnObjectPixel) {
  const Eigen::Vector3d centre = kSphereCentre;
  const SyntheticScene scene = ProofScene();
  cv::RNG rng(12);
  for (size_t l = 0; l < 3; ++l) {
    const auto cams = ProofCameras(l);
    const VolumeQuery q(test::ExactViews(cams, scene), test::BigBox());
    int said = 0, close = 0;
    for (int k = 0; k < 4000; ++k) {
      // An eye 1.5 m out, looking at the centre; a block of 2..16 pixels of a
      // 320-pixel view, between two depths 1 to 40 cm apart.
      const Eigen::Vector3d eye = centre + 1.5 * Eigen::Vector3d(rng.gaussian(1), rng.gaussian(1), 0.3).normalized();
      const NovelView view = NovelView::FromFov(320, 240, 1.0, LookAt(eye, centre, {0, 0, 1}));
      const double u0 = rng.uniform(80.0, 240.0), v0 = rng.uniform(50.0, 190.0);
      const double u1 = u0 + rng.uniform(2.0, 16.0), v1 = v0 + rng.uniform(2.0, 16.0);
      const double z0 = rng.uniform(1.0, 2.0), z1 = z0 + rng.uniform(0.01, 0.4);
      const Eigen::Vector3d ray[4] = {view.EyeRay(u0, v0), view.EyeRay(u1, v0), view.EyeRay(u0, v1),
                                      view.EyeRay(u1, v1)};
      // The piece as a bundle of the block's corner rays.
      const Eigen::Matrix3d& Rv = view.world_from_eye.rotation;
      VolumeQuery::RayBundle bundle;
      q.BundleOf(view.world_from_eye.translation, {Rv * ray[0], Rv * ray[1], Rv * ray[2], Rv * ray[3]}, &bundle);
      size_t cam = 0;
      if (q.CountWholeBackground(bundle, z0, z1, 1, &cam) == 0) continue;
      ++said;
      const detail::FastCamera& f = q.fast()[cam];
      cv::Mat near_object;  // object pixels grown by two
      cv::dilate(q.views()[cam].map, near_object, cv::Mat::ones(5, 5, CV_8UC1));
      const Eigen::Vector3f A = (cams[cam].cam_from_world * view.world_from_eye.translation).cast<float>();
      const Eigen::Matrix3d R = cams[cam].cam_from_world.rotation * view.world_from_eye.rotation;
      bool passes_close = false;
      for (int j = 0; j < 64; ++j) {
        // A ray of the block (its pixel at any point of it, edges included)
        // at a depth between the two, as the sweep makes its points.
        const double u = j == 0 ? u0 : j == 1 ? u1 : rng.uniform(u0, u1);
        const double v = j == 0 ? v0 : j == 1 ? v1 : rng.uniform(v0, v1);
        const float t = j == 0 ? float(z0) : j == 1 ? float(z1) : float(rng.uniform(z0, z1));
        const Eigen::Vector3f B = (R * view.EyeRay(u, v)).cast<float>();
        const Eigen::Vector3f X = A + t * B;
        ASSERT_EQ(VolumeQuery::VoteFast(f, X.x(), X.y(), X.z()), Vote::kBackground)
            << "lens " << l << ", camera " << cam << ", pixel " << u << ", " << v << ", depth " << t;
        const auto uv = cams[cam].Project(cams[cam].cam_from_world.Inverse() * X.cast<double>());
        if (uv && cams[cam].InImage(*uv) && near_object.at<uint8_t>(int(uv->y()), int(uv->x())) != 0)
          passes_close = true;
      }
      close += passes_close;
    }
    // Positive controls: proofs are common, and some of them within two
    // pixels of the object (fewer through a lens, whose bulge widens the
    // proof's rectangle).
    EXPECT_GT(said, 2000) << "lens " << l;
    EXPECT_GT(close, l == 0 ? 30 : 2) << "lens " << l;
  }
}

TEST(VolumeQuery, RejectsMapOfWrongSize) {
  auto views = test::SphereViews(2, 64, 48, kSphereCentre, kSphereRadius);
  views[0].map = cv::Mat(10, 10, CV_8UC1);
  EXPECT_THROW(VolumeQuery(views, test::BigBox()), std::invalid_argument);
}

}  // namespace
}  // namespace hullpipe
