// hullpipe_openxr (docs/hmd.md, "An OpenXR client"): a headset's views from an
// OpenXR runtime, through the Khronos loader nobody here wrote, into EyeViews.
// The runtime is tests/fake_openxr_runtime.cc, whose eyes follow a script
// (tests/fake_openxr_script.h) that the checks below state independently:
// each eye's centre, optical axis and image up in the rig's world.
#include <chrono>
#include <csignal>
#include <cmath>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "fake_openxr_script.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/dds.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/openxr/xr_eyes.h"
#include "hullpipe/pipeline/clock.h"
#include "test_util.h"

namespace hullpipe {
namespace {

// The lab's registration of the runtime's stage (y up) to a rig's world with z
// down (the Utrecht rig's): a quarter turn about x, then a shift.
constexpr const char* kWorldFromStage = "0.5,-0.2,0.1,-0.70710678118654752,0,0,0.70710678118654752";
Rigid3d WorldFromStage() {
  Rigid3d X;
  X.rotation = Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  X.translation = {0.5, -0.2, 0.1};
  return X;
}

// The head's turn in the stage: kYaw about +y.
Eigen::Matrix3d StageFromHead() { return Eigen::AngleAxisd(fake_xr::kYaw, Eigen::Vector3d::UnitY()).toRotationMatrix(); }

// An eye as the checks read it: where it is, where it looks (OpenCV +z) and
// which way is up in its image (OpenCV -y), in the rig's world.
void ExpectEyeIs(const Rigid3d& world_from_eye, const Eigen::Vector3d& position_stage, double tolerance,
                 const std::string& what) {
  const Rigid3d W = WorldFromStage();
  EXPECT_LT((world_from_eye.translation - W * position_stage).norm(), tolerance) << what;
  // An OpenXR view looks along its -z, its image's up is its +y.
  const Eigen::Vector3d forward = W.rotation * StageFromHead() * Eigen::Vector3d(0, 0, -1);
  const Eigen::Vector3d up = W.rotation * StageFromHead() * Eigen::Vector3d(0, 1, 0);
  EXPECT_LT((world_from_eye.rotation.col(2) - forward).norm(), tolerance) << what << ": optical axis";
  EXPECT_LT((-world_from_eye.rotation.col(1) - up).norm(), tolerance) << what << ": image up";
  EXPECT_TRUE(IsRotation(world_from_eye.rotation)) << what;
}

XrView ViewOf(const fake_xr::ScriptedEye& e) {
  XrView v{XR_TYPE_VIEW};
  v.pose.position = {float(e.position[0]), float(e.position[1]), float(e.position[2])};
  v.pose.orientation = {float(e.orientation_xyzw[0]), float(e.orientation_xyzw[1]), float(e.orientation_xyzw[2]),
                        float(e.orientation_xyzw[3])};
  v.fov = {e.fov[0], e.fov[1], e.fov[2], e.fov[3]};
  return v;
}

// XrPosef carries float32: positions near 2 m round by ~1e-7 m, unit vectors by
// ~1e-7; 1e-6 is well above that and far below any wrong axis or offset.
constexpr double kFloatTolerance = 1e-6;

TEST(OpenXr, EachViewIsRegisteredIntoTheRigsWorldInOpenCvsAxes) {
  const XrView views[2] = {ViewOf(fake_xr::EyeAt(40, 0)), ViewOf(fake_xr::EyeAt(40, 1))};
  const XrViewStateFlags valid = XR_VIEW_STATE_POSITION_VALID_BIT | XR_VIEW_STATE_ORIENTATION_VALID_BIT;
  const Rigid3d W = openxr::RigidFromPoseText(kWorldFromStage, "--world-from-space");
  const EyeViewsSample s = openxr::EyeViewsFromXr(views, 2, valid, W, 123, 7);
  EXPECT_EQ(s.stamp_ns, 123);
  EXPECT_EQ(s.tracker_id, 7u);
  for (int k = 0; k < 2; ++k) {
    const fake_xr::ScriptedEye e = fake_xr::EyeAt(40, k);
    ExpectEyeIs(s.world_from_eye[size_t(k)], {e.position[0], e.position[1], e.position[2]}, kFloatTolerance,
                k ? "right eye" : "left eye");
    EXPECT_EQ(s.fov[size_t(k)].left, double(e.fov[0]));
    EXPECT_EQ(s.fov[size_t(k)].down, double(e.fov[3]));
  }
  // The eyes an IPD apart along the head's x, the right eye on its +x side.
  const Eigen::Vector3d left_to_right = s.world_from_eye[1].translation - s.world_from_eye[0].translation;
  EXPECT_NEAR(left_to_right.norm(), 2 * fake_xr::kHalfIpd, kFloatTolerance);
  EXPECT_GT(left_to_right.dot(s.world_from_eye[0].rotation.col(0)), 0.06);

  // What cannot be drawn from is refused, naming why.
  EXPECT_THROW(openxr::EyeViewsFromXr(views, 1, valid, W, 0, 7), std::invalid_argument);
  EXPECT_THROW(openxr::EyeViewsFromXr(views, 2, XR_VIEW_STATE_POSITION_VALID_BIT, W, 0, 7), std::invalid_argument);
  XrView bad[2] = {views[0], views[1]};
  bad[1].fov.angleLeft = 0.95f;  // left of right
  try {
    openxr::EyeViewsFromXr(bad, 2, valid, W, 0, 7);
    ADD_FAILURE() << "a crossed fov accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("view 1 (right)"), std::string::npos) << e.what();
  }
  bad[1] = views[1];
  bad[0].pose.orientation = {0, 0, 0, 0};
  EXPECT_THROW(openxr::EyeViewsFromXr(bad, 2, valid, W, 0, 7), std::invalid_argument);
  bad[0] = views[0];
  bad[0].pose.position.x = std::nanf("");
  EXPECT_THROW(openxr::EyeViewsFromXr(bad, 2, valid, W, 0, 7), std::invalid_argument);
  // The registration's text.
  EXPECT_THROW(openxr::RigidFromPoseText("1,2,3", "--world-from-space"), std::invalid_argument);
  EXPECT_THROW(openxr::RigidFromPoseText("1,2,3,0,0,0,0", "--world-from-space"), std::invalid_argument);
  EXPECT_THROW(openxr::RigidFromPoseText("1,2,x,0,0,0,1", "--world-from-space"), std::invalid_argument);
  EXPECT_EQ(openxr::XrResultName(XR_ERROR_RUNTIME_UNAVAILABLE), "XR_ERROR_RUNTIME_UNAVAILABLE");
  EXPECT_EQ(openxr::XrResultName(XrResult(-987654)), "XrResult(-987654)");
}

class OpenXrProcess : public ::testing::Test {
 protected:
  OpenXrProcess() : dir_(test::TempDir("openxr")), config_(test::WriteLoopbackConfig(dir_)), domain_(test::UniqueDomain()) {
    setenv("CYCLONEDDS_URI", ("file://" + config_).c_str(), 1);
    manifest_ = (dir_ / "fake_runtime.json").string();
    std::ofstream(manifest_) << R"({"file_format_version": "1.0.0", "runtime": {"name": "hullpipe fake", )"
                             << R"("library_path": ")" << HULLPIPE_FAKE_XR_RUNTIME << "\"}}\n";
  }
  // hullpipe_openxr with `args`, the fake runtime as the active one, and `env`.
  std::unique_ptr<test::Process> Start(std::vector<std::string> args,
                                       std::vector<std::pair<std::string, std::string>> env = {},
                                       const std::string& manifest = "") {
    args.insert(args.begin(), {test::BinDir() + "/hullpipe_openxr", "--domain", std::to_string(domain_),
                               "--dds-config", config_});
    env.push_back({"XR_RUNTIME_JSON", manifest.empty() ? manifest_ : manifest});
    return std::make_unique<test::Process>(args, Log(), env);
  }
  std::string Log() const { return (dir_ / "openxr.log").string(); }
  std::filesystem::path dir_;
  std::string config_, manifest_;
  uint32_t domain_;
};

// The whole path: the loader loads the runtime, the client runs a headless
// session, and each frame's eyes arrive as EyeViews where the script put them,
// registered into the rig's world; frames the runtime marks untracked are not
// sent (counted, named once); the client ends when the runtime ends the session.
TEST_F(OpenXrProcess, ALoadedRuntimesEyesArriveAsEyeViewsInTheRigsWorld) {
  dds::Participant p(domain_);
  dds::Reader<hullpipe_msg_EyeViews> reader(p, "hullpipe/eye_views", dds::QosSpec{false, false, 128});
  const int64_t start_ns = NowNs();
  auto client = Start({"--world-from-space", kWorldFromStage, "--tracker-id", "9"},
                      {{"HULLPIPE_FAKE_XR_EXIT_AFTER", "60"}, {"HULLPIPE_FAKE_XR_UNTRACKED_EVERY", "7"}});
  std::vector<EyeViewsSample> got;
  const double until = MonotonicSeconds() + 60;
  const auto take = [&] {
    reader.TakeEach([&](const hullpipe_msg_EyeViews& m, const dds_sample_info_t&) { got.push_back(dds::EyeViewsFromMsg(m)); });
  };
  while (client->Running() && MonotonicSeconds() < until) {
    take();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_EQ(client->Wait(10), 0) << test::ReadFile(Log());
  take();
  const int64_t end_ns = NowNs();
  const std::string log = test::ReadFile(Log());
  EXPECT_NE(log.find("OpenXR runtime hullpipe fake runtime 1.2.3"), std::string::npos) << log;
  // 60 frames, of which n = 6, 13, ..., 55 untracked: 52 sent.
  EXPECT_NE(log.find("sent 52 eye views of 60 frames; 8 untracked, 0 refused"), std::string::npos) << log;
  size_t named = 0;
  for (size_t k = log.find("views not sent: tracking lost"); k != std::string::npos;
       k = log.find("views not sent: tracking lost", k + 1))
    ++named;
  EXPECT_EQ(named, 1u) << "named once";
  // Best-effort on loopback into a deep reader: all but a stray few arrive.
  EXPECT_GE(got.size(), 40u);
  EXPECT_LE(got.size(), 52u);
  const Rigid3d W = WorldFromStage();
  int64_t last_stamp = 0;
  for (const EyeViewsSample& s : got) {
    EXPECT_EQ(s.tracker_id, 9u);
    // The frame from the left eye's x along the stage.
    const Eigen::Vector3d left_stage = W.Inverse() * s.world_from_eye[0].translation;
    const long n = std::lround((left_stage.x() + fake_xr::kHalfIpd * std::cos(fake_xr::kYaw)) / 0.001);
    ASSERT_GE(n, 0);
    EXPECT_NE(n % 7, 6) << "an untracked frame's views were sent";
    for (int k = 0; k < 2; ++k) {
      const fake_xr::ScriptedEye e = fake_xr::EyeAt(uint64_t(n), k);
      ExpectEyeIs(s.world_from_eye[size_t(k)], {e.position[0], e.position[1], e.position[2]}, kFloatTolerance,
                  "frame " + std::to_string(n) + (k ? " right" : " left"));
      EXPECT_EQ(s.fov[size_t(k)].right, double(e.fov[1]));
      EXPECT_EQ(s.fov[size_t(k)].up, double(e.fov[2]));
    }
    // Stamped at the frame's predicted display time on hullpipe's clock (the
    // runtime predicts 20 ms ahead).
    EXPECT_GT(s.stamp_ns, last_stamp);
    EXPECT_GE(s.stamp_ns, start_ns);
    EXPECT_LE(s.stamp_ns, end_ns + 100'000'000);
    last_stamp = s.stamp_ns;
  }
}

// SIGINT: the client ends its session and exits 0 within a second.
TEST_F(OpenXrProcess, SigintEndsTheSessionWithinASecond) {
  dds::Participant p(domain_);
  dds::Reader<hullpipe_msg_EyeViews> reader(p, "hullpipe/eye_views", dds::QosSpec{false, false, 128});
  auto client = Start({});
  size_t got = 0;
  const double until = MonotonicSeconds() + 30;
  while (got < 5 && client->Running() && MonotonicSeconds() < until) {
    got += reader.TakeEach([](const hullpipe_msg_EyeViews&, const dds_sample_info_t&) {});
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_GE(got, 5u) << test::ReadFile(Log());
  const double t0 = MonotonicSeconds();
  client->Signal(SIGINT);
  EXPECT_EQ(client->Wait(10), 0) << test::ReadFile(Log());
  EXPECT_LT(MonotonicSeconds() - t0, 1.0 * test::TimeScale());
  EXPECT_NE(test::ReadFile(Log()).find("sent "), std::string::npos);
}

// No runtime, a runtime with no headless session, bad flags: exit 1 with one
// line naming the call or the flag. (The positive control is the test above:
// the same client and runtime, exit 0.)
TEST_F(OpenXrProcess, NoRuntimeNoHeadlessSessionOrBadFlagsExitNonZeroNamingWhy) {
  struct Case {
    std::vector<std::string> args;
    std::vector<std::pair<std::string, std::string>> env;
    std::string manifest, says;
  };
  const std::vector<Case> cases = {
      {{}, {}, (dir_ / "no_such_runtime.json").string(), "xrEnumerateInstanceExtensionProperties"},
      {{}, {{"HULLPIPE_FAKE_XR_HEADLESS", "0"}}, "", "XR_MND_headless"},
      {{"--space", "moon"}, {}, "", "--space"},
      {{"--world-from-space", "1,2,3"}, {}, "", "--world-from-space"},
  };
  for (const Case& c : cases) {
    auto client = Start(c.args, c.env, c.manifest);
    EXPECT_EQ(client->Wait(30), 1) << c.says << ": " << test::ReadFile(Log());
    const std::string log = test::ReadFile(Log());
    EXPECT_NE(log.find(c.says), std::string::npos) << log;
    size_t errors = 0;
    for (size_t k = log.find("error"); k != std::string::npos; k = log.find("error", k + 1)) ++errors;
    EXPECT_EQ(errors, 1u) << "one line: " << log;
  }
}

}  // namespace
}  // namespace hullpipe
