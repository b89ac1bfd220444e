// The rig's world (up, floor, orbit, workspace) stated, derived and read in each
// convention: a z-down (Utrecht) and a z-up world, the Utrecht layout holding
// either, and the rig file's `world` and mask keys.
#include "hullpipe/geometry/rig_world.h"

#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

namespace fs = std::filesystem;

// 4 cameras on a ring 2 m above the floor looking at a point 0.8 m up, in a
// world whose up is `up` (+z or -z) and whose floor is the plane through 0.
std::vector<Camera> Ring(const Eigen::Vector3d& up) {
  std::vector<Camera> cams;
  const Eigen::Vector3d target = 0.8 * up;
  for (int i = 0; i < 4; ++i) {
    const double a = 1.5707963 * i + 0.4;
    const Eigen::Vector3d eye(3 * std::cos(a), 3 * std::sin(a), 0);
    cams.push_back(LookingCamera(i + 1, eye + 2.0 * up, target, up, 644, 486, 1.1));
  }
  return cams;
}

TEST(RigWorld, UpIsDerivedFromTheCamerasInEitherConvention) {
  for (const Eigen::Vector3d& up : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, -1)}) {
    double spread = 0;
    EXPECT_EQ(DeriveUp(Ring(up), 10.0, &spread), up);
    EXPECT_GT(spread, 5.0);  // the cameras look down ~20 degrees: their image-ups tilt
    EXPECT_LT(spread, 30.0);
  }
  // A tilted world (up 20 degrees off z) is not snapped to z.
  const Eigen::Vector3d tilted = Eigen::Vector3d(std::sin(0.35), 0, std::cos(0.35));
  const Eigen::Vector3d got = DeriveUp(Ring(tilted));
  EXPECT_GT(got.dot(tilted), std::cos(1e-6));  // at right angles to the level cameras' x-axes: exact
  EXPECT_LT(std::abs(got.z()), 0.999);
  // Cameras rolled every way: no up to derive.
  // Two cameras, one upside down (rolled 180 degrees about its optical axis).
  std::vector<Camera> rolled = {Ring({0, 0, 1})[0], Ring({0, 0, 1})[0]};
  rolled[1].cam_from_world.rotation =
      Eigen::AngleAxisd(3.14159265358979, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
      rolled[1].cam_from_world.rotation;
  EXPECT_THROW(DeriveUp(rolled), std::invalid_argument);
}

// Cameras on three rings, each covering only half the circle and looking down
// at the person from one side of the room (a published 24-view set): their
// mean image-up leans toward that side by over ten degrees; the direction at
// right angles to their image x-axes (level cameras) is the truth, in a world
// whose up is no axis. `check` says the two disagree; one rolled camera is left
// out; a full ring (the control) gives no such warning.
TEST(RigWorld, UpFromLevelCamerasLookingDownFromOneSide) {
  const Eigen::Vector3d truth = Eigen::Vector3d(0.3, -0.2, 1).normalized();
  const Eigen::Vector3d a = truth.unitOrthogonal(), b = truth.cross(a), target = 1.0 * truth;
  auto rig = [&](double from_deg, double to_deg) {
    std::vector<Camera> cams;
    for (const double h : {1.5, 2.5, 3.5})
      for (int i = 0; i < 8; ++i) {
        const double phi = (from_deg + (to_deg - from_deg) * i / 8) * 3.14159265358979 / 180;
        const Eigen::Vector3d eye = 3.0 * (std::cos(phi) * a + std::sin(phi) * b) + h * truth;
        cams.push_back(LookingCamera(int(cams.size()) + 1, eye, target, truth, 640, 480, 1.0));
      }
    return cams;
  };
  auto deg = [](const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
    return std::acos(std::clamp(u.normalized().dot(v.normalized()), -1.0, 1.0)) * 180 / 3.14159265358979;
  };
  RigWorld world;
  world.up = truth;
  auto warns = [&](const std::vector<Camera>& cams) {
    for (const auto& w : CheckRig(cams, DefaultWorkspace(cams), world).warnings)
      if (w.find("degrees apart") != std::string::npos) return true;
    return false;
  };
  std::vector<Camera> half = rig(-80, 80);
  const UpEstimates e = EstimateUp(half);
  ASSERT_TRUE(e.level.has_value());
  EXPECT_LT(deg(*e.level, truth), 1e-6);  // level cameras: exact
  EXPECT_GT(deg(e.mean_image_up, truth), 10.0) << "the mean leans toward the cameras' side";
  EXPECT_LT(deg(DeriveUp(half), truth), 1e-6);
  EXPECT_TRUE(warns(half));
  // A camera rolled 90 degrees about its axis (mounted portrait): left out.
  half[5].cam_from_world.rotation =
      Eigen::AngleAxisd(1.5707963, Eigen::Vector3d::UnitZ()).toRotationMatrix() * half[5].cam_from_world.rotation;
  const UpEstimates r = EstimateUp(half);
  EXPECT_EQ(r.rolled, 1);
  EXPECT_LT(deg(*r.level, truth), 1e-6);
  // The control: cameras all round agree with themselves.
  const std::vector<Camera> full = rig(0, 360);
  EXPECT_LT(deg(EstimateUp(full).mean_image_up, truth), 1.0);
  EXPECT_FALSE(warns(full));
}

TEST(RigWorld, StageFrameHasZUpAndItsOriginOnTheFloor) {
  for (const Eigen::Vector3d& up : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, -1)}) {
    RigWorld w;
    w.up = up;
    w.floor = RigWorld::Floor::kPlane;
    w.floor_height = 0.25;
    Aabb ws;
    ws.min = Eigen::Vector3d(-1, -1, -2);
    ws.max = Eigen::Vector3d(3, 1, 2);
    const Rigid3d s = StageFrame(w, ws);
    EXPECT_NEAR((s.rotation.col(2) - up).norm(), 0, 1e-12);
    EXPECT_NEAR(s.rotation.determinant(), 1, 1e-12);
    EXPECT_NEAR(up.dot(s.translation), 0.25, 1e-12);                       // on the floor
    EXPECT_NEAR((s.translation - up.dot(s.translation) * up - Eigen::Vector3d(1, 0, 0)).norm(), 0, 1e-12);
  }
}

TEST(RigWorld, CommonViewAndOrbitFrameWhatEveryCameraSees) {
  const auto cams = Ring({0, 0, 1});
  const Aabb common = CommonViewWorkspace(cams);
  ASSERT_FALSE(common.empty());
  EXPECT_TRUE(common.Contains(Eigen::Vector3d(0, 0, 0.8)));  // the point they look at
  EXPECT_FALSE(common.Contains(cams[0].Center()));
  EXPECT_LT((common.max - common.min).maxCoeff(), (DefaultWorkspace(cams).max - DefaultWorkspace(cams).min).maxCoeff());
  const double r = FramingRadius(common, 60);
  EXPECT_NEAR(r, 1.1 * 0.5 * (common.max - common.min).norm() / std::tan(3.14159265358979 / 6), 1e-9);
}

// A Utrecht-layout directory (cam<N>/config.xml, size from video.avi) holding
// `cams`: translations in millimetres, rotations as Rodrigues vectors.
fs::path WriteUtrechtLayout(const std::string& tag, const std::vector<Camera>& cams) {
  const fs::path dir = test::TempDir(tag);
  for (const auto& c : cams) {
    const fs::path cd = dir / ("cam" + std::to_string(c.id));
    fs::create_directories(cd);
    // The size probe reads an image first: a PNG named video.avi will do.
    cv::imwrite((cd / "frame.png").string(), cv::Mat(c.height, c.width, CV_8UC3, cv::Scalar(0, 0, 0)));
    fs::rename(cd / "frame.png", cd / "video.avi");
    cv::Mat r(3, 3, CV_64F), rvec;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) r.at<double>(a, b) = c.cam_from_world.rotation(a, b);
    cv::Rodrigues(r, rvec);
    cv::FileStorage f((cd / "config.xml").string(), cv::FileStorage::WRITE);
    f << "CameraMatrix" << (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx - 0.5, 0, c.fy, c.cy - 0.5, 0, 0, 1);
    f << "DistortionCoeffs" << cv::Mat::zeros(5, 1, CV_64F);
    f << "Rotation" << rvec;
    f << "Translation" << (cv::Mat_<double>(3, 1) << c.cam_from_world.translation.x() * 1000,
                           c.cam_from_world.translation.y() * 1000, c.cam_from_world.translation.z() * 1000);
  }
  return dir;
}

TEST(RigWorld, UtrechtLayoutTakesZUpOrZDownFromTheCameras) {
  // z down (the Utrecht rig): the workspace ends 2 cm below the floor, z = 0.02.
  const Rig down = LoadRig(WriteUtrechtLayout("utrecht_down", Ring({0, 0, -1})).string());
  EXPECT_EQ(down.world.up, Eigen::Vector3d(0, 0, -1));
  EXPECT_EQ(down.world.floor, RigWorld::Floor::kPlane);
  EXPECT_DOUBLE_EQ(down.workspace.max.z(), 0.02);
  EXPECT_TRUE(down.notes.empty());
  // z up in the same layout: the cap goes on the other side (it used to cut
  // away everything above the floor, without a word).
  const Rig up = LoadRig(WriteUtrechtLayout("utrecht_up", Ring({0, 0, 1})).string());
  EXPECT_EQ(up.world.up, Eigen::Vector3d(0, 0, 1));
  EXPECT_DOUBLE_EQ(up.workspace.min.z(), -0.02);
  EXPECT_GT(up.workspace.max.z(), 2.0);
  ASSERT_EQ(up.notes.size(), 1u);
  EXPECT_NE(up.notes[0].find("z points up"), std::string::npos) << up.notes[0];
  EXPECT_TRUE(up.workspace.Contains(Eigen::Vector3d(0, 0, 0.8)));
}

TEST(RigWorld, RigFileStatesTheWorldAndMasksAndRoundTrips) {
  const auto dir = test::TempDir("world_yaml");
  Rig rig;
  rig.source = (dir / "rig.yaml").string();
  for (const auto& c : Ring({0, 0, 1})) {
    RigCamera rc;
    rc.camera = c;
    rc.mask_threshold = 30;
    rc.mask_channel = RigCamera::MaskChannel::kAlpha;
    rig.cameras.push_back(rc);
  }
  rig.workspace = DefaultWorkspace(rig.Cameras());
  rig.world.up = {0, 0, 1};
  rig.world.floor = RigWorld::Floor::kPlane;
  rig.world.floor_height = 0.05;
  rig.world.orbit_radius = 2.5;
  rig.world.orbit_height = 0.4;
  WriteRigYaml(rig, rig.source);
  const Rig back = LoadRig(rig.source);
  EXPECT_EQ(back.world.up, Eigen::Vector3d(0, 0, 1));
  EXPECT_EQ(back.world.floor, RigWorld::Floor::kPlane);
  EXPECT_DOUBLE_EQ(back.world.floor_height, 0.05);
  EXPECT_DOUBLE_EQ(back.world.orbit_radius, 2.5);
  EXPECT_DOUBLE_EQ(back.world.orbit_height, 0.4);
  EXPECT_TRUE(back.world.up_stated && back.world.floor_stated && back.world.orbit_stated);
  EXPECT_EQ(back.cameras[0].mask_threshold, 30);
  EXPECT_EQ(back.cameras[0].mask_channel, RigCamera::MaskChannel::kAlpha);
  // floor: hull / none, and the bad values, each named.
  std::ifstream in(rig.source);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  // Replaces the line that starts (after its indent) with `from` by `to`.
  auto with = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    const size_t at = t.find(from);
    t.replace(at, t.find('\n', at) - at, to);
    std::ofstream(dir / "edit.yaml") << t;
    return (dir / "edit.yaml").string();
  };
  EXPECT_EQ(LoadRig(with("floor: 0.05", "floor: hull")).world.floor, RigWorld::Floor::kUnderHull);
  EXPECT_EQ(LoadRig(with("floor: 0.05", "floor: none")).world.floor, RigWorld::Floor::kNone);
  for (const auto& [from, to, key] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"floor: 0.05", "floor: ceiling", "'floor'"},
           {"orbit_radius: 2.5", "orbit_radius: -1", "'orbit_radius'"},
           {"up: [0, 0, 1]", "up: [0, 0, 0]", "'up'"},
           {"orbit_height: 0.4", "orbit_hight: 0.4", "unknown key 'orbit_hight'"},
           {"mask_threshold: 30", "mask_threshold: 0", "'mask_threshold'"},
           {"mask_channel: alpha", "mask_channel: purple", "'mask_channel'"}}) {
    try {
      LoadRig(with(from, to));
      ADD_FAILURE() << to << " was taken";
    } catch (const CalibrationError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
  // Without `world`, derived: up from the cameras, floor under the hull, an orbit.
  std::string t = text;
  t.erase(t.find("world:"), t.find('\n', t.find("orbit_height:")) - t.find("world:"));
  std::ofstream(dir / "noworld.yaml") << t;
  const Rig derived = LoadRig((dir / "noworld.yaml").string());
  EXPECT_EQ(derived.world.up, Eigen::Vector3d(0, 0, 1));
  EXPECT_FALSE(derived.world.up_stated);
  EXPECT_EQ(derived.world.floor, RigWorld::Floor::kUnderHull);
  EXPECT_NEAR(derived.world.orbit_radius, FramingRadius(CommonViewWorkspace(derived.Cameras())), 1e-9);
}

TEST(RigWorld, MasksAreThresholdedOnTheChannelTheRigSays) {
  RigCamera rc;
  rc.camera.id = 7;
  // Background values 1..25 (a published mask's JPEG noise), object 255.
  cv::Mat grey(4, 8, CV_8UC1);
  for (int i = 0; i < 32; ++i) grey.at<uint8_t>(i / 8, i % 8) = i % 4 == 0 ? 255 : uint8_t(1 + i % 25);
  const cv::Mat map = MaskToObjectPixelMap(grey, rc);
  EXPECT_EQ(cv::countNonZero(map), 8);  // "any non-zero" would give 32
  EXPECT_EQ(map.type(), CV_8UC1);
  // 4 channels: which one must be said; then the alpha.
  cv::Mat bgra(4, 8, CV_8UC4, cv::Scalar(255, 255, 255, 0));
  bgra(cv::Rect(0, 0, 3, 4)).setTo(cv::Scalar(255, 255, 255, 255));
  try {
    MaskToObjectPixelMap(bgra, rc);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("camera 7: mask: has 4 channels"), std::string::npos) << e.what();
  }
  rc.mask_channel = RigCamera::MaskChannel::kAlpha;
  EXPECT_EQ(cv::countNonZero(MaskToObjectPixelMap(bgra, rc)), 12);
  rc.mask_channel = RigCamera::MaskChannel::kLuma;
  EXPECT_EQ(cv::countNonZero(MaskToObjectPixelMap(bgra, rc)), 32);  // white everywhere
  // 16-bit masks scale to 8 bits.
  cv::Mat deep(2, 2, CV_16UC1, cv::Scalar(65535));
  deep.at<uint16_t>(0, 0) = 1000;
  rc.mask_channel = RigCamera::MaskChannel::kUnset;
  EXPECT_EQ(cv::countNonZero(MaskToObjectPixelMap(deep, rc)), 3);
}

}  // namespace
}  // namespace hullpipe
