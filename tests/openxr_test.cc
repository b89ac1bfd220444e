// hullpipe_openxr (docs/hmd.md, "An OpenXR client"): a headset's views from an
// OpenXR runtime, through the Khronos loader nobody here wrote, into EyeViews.
// The runtime is tests/fake_openxr_runtime.cc, whose eyes follow a script
// (tests/fake_openxr_script.h) that the checks below state independently:
// each eye's centre, optical axis and image up in the rig's world. With
// --display (docs/hmd.md, "Display") the runtime reads back what each eye
// would show and the pose and fov each image is said to be drawn from.
#include <chrono>
#include <csignal>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "fake_openxr_script.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/dds.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/openxr/eye_images.h"
#include "hullpipe/openxr/xr_display.h"
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
Eigen::Matrix3d StageFromHead() {
  return Eigen::AngleAxisd(fake_xr::kYaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
}

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

// A layer's pose is EyeViewsFromXr's inverse: the runtime's own view pose
// comes back from the eye registered into the world (float32 again: 1e-6).
TEST(OpenXr, ALayersPoseIsTheEyesPoseBackInTheRuntimesSpace) {
  const XrView views[2] = {ViewOf(fake_xr::EyeAt(17, 0)), ViewOf(fake_xr::EyeAt(17, 1))};
  const XrViewStateFlags valid = XR_VIEW_STATE_POSITION_VALID_BIT | XR_VIEW_STATE_ORIENTATION_VALID_BIT;
  const Rigid3d W = WorldFromStage();
  const EyeViewsSample s = openxr::EyeViewsFromXr(views, 2, valid, W, 0, 1);
  for (int k = 0; k < 2; ++k) {
    const XrPosef p = openxr::XrPoseInSpace(W, s.world_from_eye[size_t(k)]);
    const XrPosef& want = views[k].pose;
    EXPECT_NEAR(p.position.x, want.position.x, kFloatTolerance);
    EXPECT_NEAR(p.position.y, want.position.y, kFloatTolerance);
    EXPECT_NEAR(p.position.z, want.position.z, kFloatTolerance);
    // q and -q are one rotation: compare |<q, q'>| with 1.
    const double dot = double(p.orientation.x) * want.orientation.x + double(p.orientation.y) * want.orientation.y +
                       double(p.orientation.z) * want.orientation.z + double(p.orientation.w) * want.orientation.w;
    EXPECT_NEAR(std::abs(dot), 1.0, kFloatTolerance);
  }
  // The format: sRGB first (the images' bytes are sRGB), else linear 8-bit,
  // else refused naming what was offered.
  EXPECT_EQ(openxr::ChooseSwapchainFormat({openxr::kGlRgba8, openxr::kGlSrgb8Alpha8}), openxr::kGlSrgb8Alpha8);
  EXPECT_EQ(openxr::ChooseSwapchainFormat({0x881A, openxr::kGlRgba8}), openxr::kGlRgba8);
  try {
    openxr::ChooseSwapchainFormat({0x881A});
    ADD_FAILURE() << "GL_RGBA16F accepted";
  } catch (const openxr::XrError& e) {
    EXPECT_NE(std::string(e.what()).find("0x881a"), std::string::npos) << e.what();
  }
}

// An 8x6 eye view with the default fov, x metres along the world's x axis
// (the pairing tests' poses).
NovelView EyeViewAt(double x) {
  Rigid3d X;
  X.translation = {x, 0, 0};
  return EyeView(EyeFov{}, 8, 6, X);
}

// Pairs: each image with the ViewPose it was drawn for, left (pose_seq) with
// right (pose_seq + 1) of one frameset; the one view's images, images without
// a pose, and pairs older than one shown are not shown.
TEST(OpenXr, ComposedEyesPairWithTheirPosesLeftWithRight) {
  openxr::EyeImagePairs pairs(4);
  constexpr uint64_t kRun = 0xabc;
  const cv::Mat img(6, 8, CV_8UC3, cv::Scalar(1, 2, 3));
  pairs.AddPose(kRun, 1, ViewEye::kMono, EyeViewAt(0));
  EXPECT_NE(pairs.AddImage(kRun, 1, ViewEye::kMono, 1, img).find("not an eye"), std::string::npos);
  pairs.AddPose(kRun, 10, ViewEye::kLeft, EyeViewAt(-0.032));
  // The right eye's image before its pose: it waits for it.
  EXPECT_EQ(pairs.AddImage(kRun, 11, ViewEye::kRight, 5, img), "");
  EXPECT_FALSE(pairs.TakeNewPair());
  pairs.AddPose(kRun, 11, ViewEye::kRight, EyeViewAt(0.032));
  EXPECT_FALSE(pairs.TakeNewPair());  // the left one missing
  EXPECT_EQ(pairs.AddImage(kRun, 10, ViewEye::kLeft, 5, img), "");
  auto pair = pairs.TakeNewPair();
  ASSERT_TRUE(pair);
  EXPECT_EQ((*pair)[0].pose_seq, 10u);
  EXPECT_EQ((*pair)[1].pose_seq, 11u);
  EXPECT_EQ((*pair)[0].view.world_from_eye.translation.x(), -0.032);
  EXPECT_EQ((*pair)[1].view.world_from_eye.translation.x(), 0.032);
  EXPECT_FALSE(pairs.TakeNewPair());  // handed out once
  // Two newer poses; the images of different framesets do not pair.
  pairs.AddPose(kRun, 12, ViewEye::kLeft, EyeViewAt(-0.1));
  pairs.AddPose(kRun, 13, ViewEye::kRight, EyeViewAt(0.1));
  EXPECT_EQ(pairs.AddImage(kRun, 12, ViewEye::kLeft, 6, img), "");
  EXPECT_EQ(pairs.AddImage(kRun, 13, ViewEye::kRight, 7, img), "");
  EXPECT_FALSE(pairs.TakeNewPair());
  // The history holds 4 poses: 10 and 11 have fallen out, and an image of
  // either waits in vain. Images without a pose wait, 4 at most: the fifth
  // pushes the first out, named.
  pairs.AddPose(kRun, 14, ViewEye::kLeft, EyeViewAt(-0.2));
  pairs.AddPose(kRun, 15, ViewEye::kRight, EyeViewAt(0.2));
  EXPECT_EQ(pairs.AddImage(kRun, 10, ViewEye::kLeft, 5, img), "");
  for (uint64_t seq : {30, 31, 32}) EXPECT_EQ(pairs.AddImage(kRun, seq, ViewEye::kLeft, 9, img), "");
  EXPECT_NE(pairs.AddImage(kRun, 33, ViewEye::kLeft, 9, img).find("no ViewPose 10"), std::string::npos);
  EXPECT_EQ(pairs.AddImage(kRun, 14, ViewEye::kLeft, 8, img), "");
  EXPECT_EQ(pairs.AddImage(kRun, 15, ViewEye::kRight, 8, img), "");
  pair = pairs.TakeNewPair();
  ASSERT_TRUE(pair);
  EXPECT_EQ((*pair)[0].frame_seq, 8u);
  EXPECT_EQ((*pair)[1].view.world_from_eye.translation.x(), 0.2);
  // An older image arriving after a newer one of its eye does not replace it.
  pairs.AddPose(kRun, 16, ViewEye::kLeft, EyeViewAt(-0.3));
  pairs.AddPose(kRun, 17, ViewEye::kRight, EyeViewAt(0.3));
  pairs.AddPose(kRun, 18, ViewEye::kLeft, EyeViewAt(-0.4));
  EXPECT_EQ(pairs.AddImage(kRun, 18, ViewEye::kLeft, 10, img), "");
  EXPECT_EQ(pairs.AddImage(kRun, 16, ViewEye::kLeft, 9, img), "");
  EXPECT_EQ(pairs.AddImage(kRun, 17, ViewEye::kRight, 9, img), "");
  EXPECT_FALSE(pairs.TakeNewPair());  // 18 stays the left eye's; 17 is not its pair
  EXPECT_EQ(pairs.counts().paired, 2u);
  EXPECT_EQ(pairs.counts().not_an_eye, 2u);
  EXPECT_EQ(pairs.counts().no_pose, 1u);
  EXPECT_EQ(pairs.counts().superseded, 3u);  // 12 and 13 by 14 and 15; 16 by 18
}


// Runs: pose_seq restarts with a restarted render_node (a new run id), whose
// pairs are shown although their pose_seqs are below the last pair's; an
// image of another run never pairs with this run's pose of the same pose_seq
// and eye.
TEST(OpenXr, ComposedEyesPairWithinOneRunAndFollowARestartedRender) {
  openxr::EyeImagePairs pairs(8);
  const cv::Mat mine(6, 8, CV_8UC3, cv::Scalar(1, 2, 3)), other(6, 8, CV_8UC3, cv::Scalar(9, 9, 9));
  pairs.AddPose(1, 40, ViewEye::kLeft, EyeViewAt(-0.03));
  pairs.AddPose(1, 41, ViewEye::kRight, EyeViewAt(0.03));
  // Another run's images of the same pose_seqs (a replay on the domain): they
  // wait for poses of their run, which never come.
  EXPECT_EQ(pairs.AddImage(2, 40, ViewEye::kLeft, 7, other), "");
  EXPECT_EQ(pairs.AddImage(2, 41, ViewEye::kRight, 7, other), "");
  EXPECT_FALSE(pairs.TakeNewPair());
  EXPECT_EQ(pairs.AddImage(1, 40, ViewEye::kLeft, 7, mine), "");
  EXPECT_EQ(pairs.AddImage(1, 41, ViewEye::kRight, 7, mine), "");
  auto pair = pairs.TakeNewPair();
  ASSERT_TRUE(pair);
  EXPECT_EQ((*pair)[0].run_id, 1u);
  EXPECT_EQ((*pair)[0].bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(1, 2, 3));
  EXPECT_EQ((*pair)[1].bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(1, 2, 3));
  // render_node restarted: run 3 numbers from 1 again; its image came before
  // its pose.
  EXPECT_EQ(pairs.AddImage(3, 2, ViewEye::kRight, 1, mine), "");
  pairs.AddPose(3, 1, ViewEye::kLeft, EyeViewAt(-0.05));
  pairs.AddPose(3, 2, ViewEye::kRight, EyeViewAt(0.05));
  EXPECT_EQ(pairs.AddImage(3, 1, ViewEye::kLeft, 1, mine), "");
  pair = pairs.TakeNewPair();
  ASSERT_TRUE(pair) << "a restarted render's first pair, pose_seq 1 after 40";
  EXPECT_EQ((*pair)[0].pose_seq, 1u);
  EXPECT_EQ((*pair)[1].run_id, 3u);
  EXPECT_EQ((*pair)[1].view.world_from_eye.translation.x(), 0.05);
  // Run 1's images after the restart find no pose of theirs.
  EXPECT_EQ(pairs.AddImage(1, 42, ViewEye::kLeft, 8, mine), "");
  EXPECT_FALSE(pairs.TakeNewPair());
  EXPECT_EQ(pairs.counts().run_changes, 1u);
  EXPECT_EQ(pairs.counts().paired, 2u);
}

// Decoding: an image is decoded only when its pair is handed out; one a newer
// image of its eye supersedes first is never decoded (render outpacing the
// headset); an image that does not decode drops its pair, counted.
TEST(OpenXr, AnImageIsDecodedOnlyWhenItsPairIsHandedOut) {
  openxr::EyeImagePairs pairs(8);
  std::vector<uint64_t> decoded;  // pose_seqs decoded
  const auto image = [&](uint64_t seq, bool good) -> openxr::DecodeImageFn {
    return [&decoded, seq, good] {
      decoded.push_back(seq);
      return good ? cv::Mat(6, 8, CV_8UC3, cv::Scalar(1, 2, 3)) : cv::Mat();
    };
  };
  for (uint64_t seq = 20; seq < 28; ++seq)
    pairs.AddPose(1, seq, seq % 2 ? ViewEye::kRight : ViewEye::kLeft, EyeViewAt(0));
  // Three pairs arrive before the headset's next frame: only the newest is decoded.
  for (uint64_t seq = 20; seq < 26; ++seq)
    EXPECT_EQ(pairs.AddImage(1, seq, seq % 2 ? ViewEye::kRight : ViewEye::kLeft, seq / 2, image(seq, true)), "");
  EXPECT_TRUE(decoded.empty());
  auto pair = pairs.TakeNewPair();
  ASSERT_TRUE(pair);
  EXPECT_EQ((*pair)[0].pose_seq, 24u);
  EXPECT_EQ((*pair)[1].bgr.size(), cv::Size(8, 6));
  EXPECT_EQ(decoded, (std::vector<uint64_t>{24, 25}));
  EXPECT_EQ(pairs.counts().decoded, 2u);
  EXPECT_EQ(pairs.counts().superseded, 4u);
  // A corrupt right eye: the pair is not handed out; its left waits for a
  // right of its pose that decodes.
  EXPECT_EQ(pairs.AddImage(1, 26, ViewEye::kLeft, 13, image(26, true)), "");
  EXPECT_EQ(pairs.AddImage(1, 27, ViewEye::kRight, 13, image(27, false)), "");
  EXPECT_FALSE(pairs.TakeNewPair());
  EXPECT_EQ(pairs.counts().undecodable, 1u);
  EXPECT_EQ(pairs.AddImage(1, 27, ViewEye::kRight, 13, image(27, true)), "");
  pair = pairs.TakeNewPair();
  ASSERT_TRUE(pair);
  EXPECT_EQ((*pair)[0].pose_seq, 26u);
  EXPECT_EQ(decoded, (std::vector<uint64_t>{24, 25, 26, 27, 27}));
}

class OpenXrProcess : public ::testing::Test {
 protected:
  OpenXrProcess()
      : dir_(test::TempDir("openxr")), config_(test::WriteLoopbackConfig(dir_)), domain_(test::UniqueDomain()) {
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
    reader.TakeEach(
        [&](const hullpipe_msg_EyeViews& m, const dds_sample_info_t&) { got.push_back(dds::EyeViewsFromMsg(m)); });
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

// One layer line of the fake runtime's layers.txt: the frame, and per eye the
// pose, fov, image size, format and the image file it dumped ("-": none new).
struct LayerEye {
  double p[3], q[4], fov[4];
  int width, height;
  int64_t format;
  std::string file;
};
struct LayerLine {
  uint64_t frame = 0;
  int layers = 0;
  std::vector<LayerEye> eyes;
};
std::vector<LayerLine> ReadLayers(const std::filesystem::path& file) {
  std::vector<LayerLine> out;
  std::ifstream f(file);
  for (std::string line; std::getline(f, line);) {
    std::istringstream ss(line);
    LayerLine l;
    std::string word;
    ss >> l.frame >> word >> l.layers;
    for (int k = 0; k < 2 * l.layers; ++k) {
      LayerEye e;
      int index = 0;
      ss >> word >> index >> e.p[0] >> e.p[1] >> e.p[2] >> e.q[0] >> e.q[1] >> e.q[2] >> e.q[3] >> e.fov[0] >>
          e.fov[1] >> e.fov[2] >> e.fov[3] >> e.width >> e.height >> e.format >> e.file;
      l.eyes.push_back(e);
    }
    out.push_back(l);
  }
  return out;
}

// An eye image of pair i: a flat grey (60 + 50 i) with the top-left quadrant
// red (left eye) or blue (right eye), so that a swapped eye, an upside-down
// or mirrored upload and a stale image each show.
cv::Mat EyePattern(int i, int eye) {
  cv::Mat img(48, 64, CV_8UC3, cv::Scalar::all(60 + 50 * i));
  img(cv::Rect(0, 0, 32, 24)).setTo(eye == 0 ? cv::Scalar(0, 0, 255) : cv::Scalar(255, 0, 0));
  return img;
}

// The whole display path: render_node's part is played here from the views
// the client sends. For three head poses the test publishes each eye's
// ViewPose (EyeView of the eye's pose and fov at 64x48) and its composited
// image; the runtime reads back each eye's swapchain image and the layer's
// pose and fov. Each must be exactly what was composited for that eye (JPEG
// of flat blocks at quality 95: within 8 levels away from the edges), upright,
// at the pose the runtime reported for the frame it was drawn for, in its
// space. Before any pair, frames carry no layer (and a monitor's composite,
// not an eye's, is not shown): the layers come from the composites alone. A
// hostile peer's oversized composites, flooding beside render's, are refused
// undecoded while render's pairs, written at render's pace, are shown.
TEST_F(OpenXrProcess, TheCompositedEyesReachTheHeadsetAtThePosesTheyWereDrawnFrom) {
  const std::filesystem::path layers = dir_ / "layers";
  std::filesystem::create_directories(layers);
  dds::Participant p(domain_);
  dds::Reader<hullpipe_msg_EyeViews> eyes(p, "hullpipe/eye_views", dds::QosSpec{false, false, 128});
  dds::Writer<hullpipe_msg_ViewPose> poses(p);
  dds::Writer<hullpipe_msg_CompositedView> images(p);
  // A hostile peer beside render: composites wider than any eye takes (the
  // runtime's 2048), for a pose the client has, written every turn of the
  // test's waits. None may be decoded or shown; render's pairs must still be.
  dds::Participant hostile(domain_);
  dds::Writer<hullpipe_msg_CompositedView> hostile_images(hostile);
  const auto oversized =
      dds::MakeCompositedViewMessage(cv::Mat(48, 2100, CV_8UC3, cv::Scalar(0, 255, 0)), 10, 100, 0, 0, {16384, 50},
                                     ViewEye::kLeft);
  // A replay of a recording on the domain: another run's poses, stamped when
  // they were recorded (no views this client sent), and its composites, green,
  // with render's pose_seqs. Its poses must not be taken nor its images shown.
  dds::Participant replay(domain_);
  dds::Writer<hullpipe_msg_ViewPose> replay_poses(replay);
  dds::Writer<hullpipe_msg_CompositedView> replay_images(replay);
  constexpr uint64_t kReplayRun = 0x5e;
  auto client = Start({"--display", "--world-from-space", kWorldFromStage},
                      {{"HULLPIPE_FAKE_XR_LAYERS_DIR", layers.string()}});
  const auto dumped = [&] {
    hostile_images.Write(oversized.msg);
    size_t n = 0;
    for (const auto& e : std::filesystem::directory_iterator(layers)) n += e.path().extension() == ".ppm";
    return n;
  };
  double until = MonotonicSeconds() + 30;
  while (images.MatchedReaders() == 0 && client->Running() && MonotonicSeconds() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_GT(images.MatchedReaders(), 0u) << test::ReadFile(Log());
  // A monitor's composite first: not an eye, not shown. Written until the
  // client names it: a best-effort sample sent before the client's reader
  // has discovered this writer is dropped (the writer may match first).
  const NovelView mono = EyeView(EyeFov{}, 64, 48, Rigid3d{});
  poses.Write(dds::ViewToMsg(mono, 1, 1, NowNs(), 0, ViewEye::kMono));
  const auto monitor = dds::MakeCompositedViewMessage(EyePattern(0, 0), 1, 1, NowNs(), 0, {1280, 95});
  until = MonotonicSeconds() + 30;
  while (test::ReadFile(Log()).find("not an eye") == std::string::npos && client->Running() &&
         MonotonicSeconds() < until) {
    images.Write(monitor.msg);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::vector<std::array<NovelView, 2>> drawn;  // per pair, each eye's view
  for (int i = 0; i < 3; ++i) {
    // The newest views the client sent, as render_node --view eyes-topic takes them.
    std::optional<EyeViewsSample> views;
    until = MonotonicSeconds() + 30;
    while (!views && client->Running() && MonotonicSeconds() < until) {
      eyes.TakeEach([&](const hullpipe_msg_EyeViews& m, const dds_sample_info_t&) { views = dds::EyeViewsFromMsg(m); });
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ASSERT_TRUE(views) << test::ReadFile(Log());
    std::array<NovelView, 2> v;
    const size_t before = dumped();
    for (int k = 0; k < 2; ++k) {
      const ViewEye eye = k ? ViewEye::kRight : ViewEye::kLeft;
      v[size_t(k)] = EyeView(views->fov[size_t(k)], 64, 48, views->world_from_eye[size_t(k)]);
      const uint64_t seq = uint64_t(10 + 2 * i + k);
      replay_poses.Write(dds::ViewToMsg(v[size_t(k)], seq, uint64_t(100 + i), views->stamp_ns - 60'000'000'000,
                                        kReplayRun, eye));
      replay_images.Write(dds::MakeCompositedViewMessage(cv::Mat(48, 64, CV_8UC3, cv::Scalar(0, 255, 0)), seq,
                                                         uint64_t(100 + i), NowNs(), kReplayRun, {1280, 95}, eye)
                              .msg);
      // As render_node stamps a pose: the stamp of the views it was drawn from.
      poses.Write(dds::ViewToMsg(v[size_t(k)], seq, uint64_t(100 + i), views->stamp_ns, 0, eye));
    }
    std::vector<dds::OwnedSample<hullpipe_msg_CompositedView>> pair;
    for (int k = 0; k < 2; ++k)
      pair.push_back(dds::MakeCompositedViewMessage(EyePattern(i, k), uint64_t(10 + 2 * i + k), uint64_t(100 + i),
                                                    NowNs(), 0, {1280, 95}, k ? ViewEye::kRight : ViewEye::kLeft));
    drawn.push_back(v);
    // render keeps its rate: the pair again each turn, as each frame brings
    // its composites (the topic is best-effort, 4 kept: a lost one comes again).
    until = MonotonicSeconds() + 30;
    while (dumped() < before + 2 && client->Running() && MonotonicSeconds() < until) {
      for (const auto& m : pair) images.Write(m.msg);
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ASSERT_EQ(dumped(), before + 2) << "pair " << i << " not shown: " << test::ReadFile(Log());
  }
  client->Signal(SIGINT);
  ASSERT_EQ(client->Wait(10), 0) << test::ReadFile(Log());
  const std::string log = test::ReadFile(Log());
  EXPECT_NE(log.find("GL_SRGB8_ALPHA8"), std::string::npos) << log;
  EXPECT_NE(log.find("showed 3 composited eye pairs"), std::string::npos) << log;
  EXPECT_NE(log.find("not an eye"), std::string::npos) << log;
  EXPECT_NE(log.find("was not drawn from this client's views"), std::string::npos) << log;
  EXPECT_NE(log.find("; 0 render run changes"), std::string::npos) << log << "the replay's run was never taken";
  EXPECT_NE(log.find("CompositedView 2100x48 is larger than the headset's largest eye image 2048x2048"),
            std::string::npos)
      << log;

  const std::vector<LayerLine> lines = ReadLayers(layers / "layers.txt");
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines.front().layers, 0) << "a layer before any composite";
  int pair = -1;
  size_t with_layer = 0;
  const Rigid3d W = WorldFromStage();
  for (const LayerLine& l : lines) {
    if (l.layers == 0) {
      EXPECT_EQ(pair, -1) << "frame " << l.frame << ": no layer after one was shown";
      continue;
    }
    ASSERT_EQ(l.layers, 1);
    ++with_layer;
    if (l.eyes[0].file != "-") ++pair;
    ASSERT_GE(pair, 0) << "a layer before its images";
    ASSERT_LT(pair, 3);
    for (int k = 0; k < 2; ++k) {
      const LayerEye& e = l.eyes[size_t(k)];
      const std::string what = "frame " + std::to_string(l.frame) + " eye " + std::to_string(k);
      EXPECT_EQ(e.width, 64) << what;
      EXPECT_EQ(e.height, 48) << what;
      EXPECT_EQ(e.format, openxr::kGlSrgb8Alpha8) << what;
      // The pose the image was drawn from, in the runtime's space: where the
      // runtime put that eye (the views the test drew from came from it).
      const XrPosef want = openxr::XrPoseInSpace(W, drawn[size_t(pair)][size_t(k)].world_from_eye);
      EXPECT_NEAR(e.p[0], want.position.x, 1e-5) << what;
      EXPECT_NEAR(e.p[1], 1.6, 1e-5) << what;  // the script's head height, independently
      EXPECT_NEAR(e.p[2], want.position.z, 1e-5) << what;
      EXPECT_NEAR(std::abs(e.q[0] * want.orientation.x + e.q[1] * want.orientation.y +
                           e.q[2] * want.orientation.z + e.q[3] * want.orientation.w),
                  1.0, 1e-5)
          << what;
      EXPECT_NEAR(e.q[1], std::sin(fake_xr::kYaw / 2) * (e.q[3] < 0 ? -1 : 1), 1e-5) << what;  // the script's turn
      // The fov the runtime reported for that eye, back from the 64x48 view.
      const fake_xr::ScriptedEye scripted = fake_xr::EyeAt(0, k);
      for (int a = 0; a < 4; ++a) EXPECT_NEAR(e.fov[a], scripted.fov[a], 1e-5) << what << " angle " << a;
      if (e.file == "-") continue;
      const cv::Mat shown = cv::imread((layers / e.file).string(), cv::IMREAD_COLOR);
      ASSERT_EQ(shown.size(), cv::Size(64, 48)) << e.file;
      const cv::Vec3b colour = k == 0 ? cv::Vec3b(0, 0, 255) : cv::Vec3b(255, 0, 0);
      const cv::Vec3b grey = cv::Vec3b::all(uchar(60 + 50 * pair));
      for (const auto& [pt, want_px] : std::vector<std::pair<cv::Point, cv::Vec3b>>{
               {{8, 6}, colour}, {{24, 18}, colour}, {{56, 6}, grey}, {{8, 42}, grey}, {{56, 42}, grey}}) {
        const cv::Vec3b got = shown.at<cv::Vec3b>(pt);
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(int(got[c]), int(want_px[c]), 8) << e.file << " at " << pt << " channel " << c;
      }
    }
  }
  EXPECT_EQ(pair, 2) << "three pairs shown";
  EXPECT_GT(with_layer, 3u) << "the last pair stays shown until the next";
}

// The same through the real pipeline: hullpipe_launch --view eyes-topic draws
// both eyes from the views the client sends, and the client shows what render
// composited. Every composited frame's pair reaches the headset (render's
// numbering of a head pose's two eyes is what the pairing expects), nothing is
// refused, and every layer's eye sits where the runtime's script put an eye
// (the head's height, its turn) with the script's fov: the pose each image was
// drawn from, carried through render and back.
TEST_F(OpenXrProcess, RendersCompositedEyesReachTheHeadsetThroughTheWholePipeline) {
  const std::filesystem::path layers = dir_ / "layers";
  std::filesystem::create_directories(layers);
  auto client = Start({"--display", "--world-from-space", kWorldFromStage},
                      {{"HULLPIPE_FAKE_XR_LAYERS_DIR", layers.string()}});
  test::Process launch({test::BinDir() + "/hullpipe_launch", "--synthetic", "--frames", "24", "--fps", "12", "--view",
                        "eyes-topic", "--width", "96", "--height", "72", "--out", (dir_ / "run").string(), "--domain",
                        std::to_string(domain_), "--dds-config", config_},
                       (dir_ / "launch.log").string());
  ASSERT_EQ(launch.Wait(120), 0) << test::ReadFile((dir_ / "launch.log").string());
  client->Signal(SIGINT);
  ASSERT_EQ(client->Wait(10), 0) << test::ReadFile(Log());
  const auto stats = test::ReadFile((dir_ / "run" / "stats.json").string());
  const size_t at = stats.find("\"frames_composited\":");
  ASSERT_NE(at, std::string::npos) << stats;
  const int composited = std::stoi(stats.substr(at + 20));
  ASSERT_GE(composited, 3) << test::ReadFile((dir_ / "launch.log").string());
  const std::string log = test::ReadFile(Log());
  const size_t shown_at = log.find("showed ");
  ASSERT_NE(shown_at, std::string::npos) << log;
  const int shown = std::stoi(log.substr(shown_at + 7));
  // Best-effort composites on loopback: all but a stray one arrive.
  EXPECT_GE(shown, composited - 2) << log;
  EXPECT_LE(shown, composited) << log;
  EXPECT_NE(log.find(" 0 composites or poses not shown"), std::string::npos) << log;
  size_t with_layer = 0, images = 0;
  for (const LayerLine& l : ReadLayers(layers / "layers.txt")) {
    if (l.layers == 0) continue;
    ++with_layer;
    for (int k = 0; k < 2; ++k) {
      const LayerEye& e = l.eyes[size_t(k)];
      EXPECT_EQ(e.width, 96);
      EXPECT_EQ(e.height, 72);
      EXPECT_NEAR(e.p[1], 1.6, 1e-5) << "frame " << l.frame;
      EXPECT_NEAR(std::abs(e.q[1]), std::sin(fake_xr::kYaw / 2), 1e-5) << "frame " << l.frame;
      const fake_xr::ScriptedEye scripted = fake_xr::EyeAt(0, k);
      for (int a = 0; a < 4; ++a) EXPECT_NEAR(e.fov[a], scripted.fov[a], 1e-5) << "frame " << l.frame;
      images += e.file != "-";
    }
  }
  EXPECT_GE(with_layer, size_t(shown));
  EXPECT_EQ(images, std::min<size_t>(64, 2 * size_t(shown)));
}

// SIGINT: the client ends its session and exits 0 within a second, headless
// and showing images.
TEST_F(OpenXrProcess, SigintEndsTheSessionWithinASecond) {
  dds::Participant p(domain_);
  dds::Reader<hullpipe_msg_EyeViews> reader(p, "hullpipe/eye_views", dds::QosSpec{false, false, 128});
  for (const std::vector<std::string>& args : {std::vector<std::string>{}, std::vector<std::string>{"--display"}}) {
    const std::string mode = args.empty() ? "headless" : "--display";
    auto client = Start(args);
    size_t got = 0;
    const double until = MonotonicSeconds() + 30;
    while (got < 5 && client->Running() && MonotonicSeconds() < until) {
      got += reader.TakeEach([](const hullpipe_msg_EyeViews&, const dds_sample_info_t&) {});
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ASSERT_GE(got, 5u) << mode << ": " << test::ReadFile(Log());
    const double t0 = MonotonicSeconds();
    client->Signal(SIGINT);
    EXPECT_EQ(client->Wait(10), 0) << mode << ": " << test::ReadFile(Log());
    EXPECT_LT(MonotonicSeconds() - t0, 1.0 * test::TimeScale()) << mode;
    EXPECT_NE(test::ReadFile(Log()).find("sent "), std::string::npos) << mode;
  }
}

// No runtime, a runtime with no headless session (or, for --display, no EGL
// binding or no usable swapchain format), bad flags: exit 1 with one line
// naming the call or the flag. (The positive control is the test above:
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
      // --display: a runtime with no EGL binding, or no format hullpipe uploads.
      {{"--display"}, {{"HULLPIPE_FAKE_XR_EGL", "0"}}, "", "XR_MNDX_egl_enable"},
      {{"--display"}, {{"HULLPIPE_FAKE_XR_FORMATS", "34842"}}, "", "xrEnumerateSwapchainFormats"},
      {{"--display", "--gl-device", "40"}, {}, "", "--gl-device 40"},
  };
  for (const Case& c : cases) {
    auto client = Start(c.args, c.env, c.manifest);
    EXPECT_EQ(client->Wait(30), 1) << c.says << ": " << test::ReadFile(Log());
    const std::string log = test::ReadFile(Log());
    EXPECT_NE(log.find(c.says), std::string::npos) << log;
    size_t errors = 0;
    for (size_t k = log.find("error"); k != std::string::npos; k = log.find("error", k + 1)) ++errors;
    EXPECT_EQ(errors, 1u) << "one line: " << log;
  }  // A flag of --display's without it: refused at parsing (CLI11's exit code),
  // naming both.
  auto client = Start({"--gl-device", "0"});
  EXPECT_NE(client->Wait(30), 0) << test::ReadFile(Log());
  EXPECT_NE(test::ReadFile(Log()).find("--gl-device requires --display"), std::string::npos) << test::ReadFile(Log());
}

}  // namespace
}  // namespace hullpipe
