// hullpipe's ROS 2 messages (docs/ros2.md) judged by a reader nobody here
// wrote: the bytes Cyclone serializes from idl/ros2.idl's types decode with
// Foxglove's ROS 2 deserializer and the ROS 2 Humble definitions Foxglove ships
// (tests/js/decode_ros2.mjs), field by field; and a tracker's pose is refused
// when it is not one.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>
#include <thread>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/dds.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/ros2/ros2_deriver.h"
#include "hullpipe/ros2/ros2_messages.h"
#include "hullpipe/ros2/ros2_schemas.h"
#include "hullpipe/ros2/ros2_topics.h"
#include "hullpipe/record/recording.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/reconstruction/stereo_views.h"
#include "hullpipe/testing/stop_timing.h"
#include "test_util.h"

namespace hullpipe {
namespace {

using nlohmann::json;

std::string Base64(const std::vector<uint8_t>& in) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const uint32_t v = uint32_t(in[i]) << 16 | uint32_t(in[i + 1]) << 8 | in[i + 2];
    for (int s : {18, 12, 6, 0}) out += k[(v >> s) & 63];
  }
  if (i + 1 == in.size()) {
    const uint32_t v = uint32_t(in[i]) << 16;
    out += k[(v >> 18) & 63], out += k[(v >> 12) & 63], out += "==";
  } else if (i + 2 == in.size()) {
    const uint32_t v = uint32_t(in[i]) << 16 | uint32_t(in[i + 1]) << 8;
    out += k[(v >> 18) & 63], out += k[(v >> 12) & 63], out += k[(v >> 6) & 63], out += '=';
  }
  return out;
}

class Ros2Messages : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::TempDir("ros2_messages");
    setenv("CYCLONEDDS_URI", ("file://" + test::WriteLoopbackConfig(dir_)).c_str(), 1);
    participant_ = std::make_unique<dds::Participant>(test::UniqueDomain());
  }
  // XCDR1 bytes of `msg` as Cyclone serializes type `kt`.
  std::vector<uint8_t> Encode(const dds::KnownType& kt, const void* msg) {
    return dds::CdrWriter(*participant_, kt, kt.qos, dds::CdrWriter::Scope::kDecodeOnly).Encode(msg);
  }
  // Each (ROS type name, bytes) decoded by Foxglove's reader, in order.
  std::vector<json> Decode(const std::vector<std::pair<std::string, std::vector<uint8_t>>>& messages) {
    const std::string in = (dir_ / "messages.txt").string(), out = (dir_ / "decoded.jsonl").string();
    {
      std::ofstream f(in);
      for (const auto& [type, bytes] : messages) f << type << " " << Base64(bytes) << "\n";
    }
    const std::string js = std::string(HULLPIPE_SOURCE_DIR) + "/tests/js";
    test::Process node({"/usr/bin/env", "node", js + "/decode_ros2.mjs", in}, out, {}, out + ".err");
    EXPECT_EQ(node.Wait(60), 0) << test::ReadFile(out + ".err");
    std::vector<json> decoded;
    std::ifstream f(out);
    for (std::string line; std::getline(f, line);) decoded.push_back(json::parse(line));
    return decoded;
  }
  std::filesystem::path dir_;
  std::unique_ptr<dds::Participant> participant_;
};

// A skewed, distorted camera: ROS's CameraInfo (K, D plumb_bob, R, P, the
// pixel convention moved by half a pixel), its transform on /tf_static, its
// map as mono8 and its JPEG passed on, a tracker's pose: every field as
// Foxglove's ROS 2 Humble reader decodes it.
TEST_F(Ros2Messages, FoxglovesRos2DecoderReadsEveryFieldHullpipeWrites) {
  Camera cam;
  cam.id = 3;
  cam.width = 64, cam.height = 48;
  cam.fx = 50.5, cam.fy = 51.25, cam.cx = 32.5, cam.cy = 24.0, cam.skew = 0.75;
  cam.distortion = {-0.2, 0.05, 0.001, -0.002, 0.01};
  cam.cam_from_world.rotation = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  cam.cam_from_world.translation = Eigen::Vector3d(0.1, -0.2, 2.5);
  Camera other = cam;
  other.id = 4;
  other.cam_from_world.translation.x() = 1.0;
  const int64_t stamp = 1'700'000'000'123'456'789;

  const auto info = ros2::MakeCameraInfo(cam, stamp);
  cv::Mat map(48, 64, CV_8UC1, cv::Scalar(0));
  map(cv::Rect(10, 5, 20, 30)).setTo(255);
  const auto mono = ros2::MakeMono8Image(map, stamp, ros2::CameraFrameId(3));
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", cv::Mat(48, 64, CV_8UC3, cv::Scalar(10, 200, 30)), jpeg);
  const auto compressed = ros2::MakeCompressedImage(jpeg, stamp, ros2::CameraFrameId(3));
  const auto tf = ros2::MakeCameraTransforms({cam, other}, stamp);
  Rigid3d head;
  head.rotation = Eigen::AngleAxisd(-1.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  head.translation = Eigen::Vector3d(0.5, 1.5, -1.7);
  const auto pose = ros2::MakePoseStamped(head, stamp, ros2::kWorldFrame);
  cv::Mat frame(2, 3, CV_8UC3);
  for (int i = 0; i < 18; ++i) frame.data[i] = uint8_t(10 * i + 1);
  const auto bgr = ros2::MakeBgr8Image(frame, stamp, ros2::CameraFrameId(3));

  // Each as Cyclone serializes the type (ros2_schemas.h Ros2KnownType).
  auto encode = [&](const char* type, const void* msg) { return Encode(ros2::Ros2KnownType(type), msg); };
  const auto decoded = Decode({
      {"sensor_msgs/msg/CameraInfo", encode("sensor_msgs/msg/CameraInfo", &info.msg)},
      {"sensor_msgs/msg/Image", encode("sensor_msgs/msg/Image", &mono.msg)},
      {"sensor_msgs/msg/CompressedImage", encode("sensor_msgs/msg/CompressedImage", &compressed.msg)},
      {"tf2_msgs/msg/TFMessage", encode("tf2_msgs/msg/TFMessage", &tf.msg)},
      {"geometry_msgs/msg/PoseStamped", encode("geometry_msgs/msg/PoseStamped", &pose.msg)},
      {"sensor_msgs/msg/Image", encode("sensor_msgs/msg/Image", &bgr.msg)},
  });
  ASSERT_EQ(decoded.size(), 6u);
  for (const json& d : decoded) ASSERT_FALSE(d.contains("error")) << d.dump();

  // CameraInfo: the header, K and P in ROS pixels (centres at integers), D, R.
  const json& ci = decoded[0];
  EXPECT_EQ(ci["header"]["stamp"]["sec"], 1'700'000'000);
  EXPECT_EQ(ci["header"]["stamp"]["nanosec"], 123'456'789);
  EXPECT_EQ(ci["header"]["frame_id"], "hullpipe_cam3");
  EXPECT_EQ(ci["width"], 64);
  EXPECT_EQ(ci["height"], 48);
  EXPECT_EQ(ci["distortion_model"], "plumb_bob");
  EXPECT_EQ(ci["d"], json({-0.2, 0.05, 0.001, -0.002, 0.01}));
  EXPECT_EQ(ci["k"], json({50.5, 0.75, 32.0, 0, 51.25, 23.5, 0, 0, 1}));
  EXPECT_EQ(ci["r"], json({1, 0, 0, 0, 1, 0, 0, 0, 1}));
  EXPECT_EQ(ci["p"], json({50.5, 0.75, 32.0, 0, 0, 51.25, 23.5, 0, 0, 0, 1, 0}));
  EXPECT_EQ(ci["binning_x"], 0);
  EXPECT_EQ(ci["roi"]["width"], 0);
  EXPECT_EQ(ci["roi"]["do_rectify"], false);

  // The map: mono8, row by row, 255 where the object is.
  const json& im = decoded[1];
  EXPECT_EQ(im["encoding"], "mono8");
  EXPECT_EQ(im["step"], 64);
  EXPECT_EQ(im["is_bigendian"], 0);
  ASSERT_EQ(im["data"].size(), 64u * 48u);
  EXPECT_EQ(im["data"][5 * 64 + 10], 255);
  EXPECT_EQ(im["data"][5 * 64 + 9], 0);
  EXPECT_EQ(im["data"][34 * 64 + 29], 255);
  EXPECT_EQ(im["data"][35 * 64 + 29], 0);

  // The JPEG, byte for byte.
  const json& cm = decoded[2];
  EXPECT_EQ(cm["format"], "jpeg");
  EXPECT_EQ(cm["data"].get<std::vector<uint8_t>>(), jpeg);

  // /tf_static: world -> each camera's optical frame, translation its centre,
  // rotation R^T (tf2's parent_from_child).
  const json& transforms = decoded[3]["transforms"];
  ASSERT_EQ(transforms.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    const Camera& c = k == 0 ? cam : other;
    const json& t = transforms[k];
    EXPECT_EQ(t["header"]["frame_id"], "hullpipe_world");
    EXPECT_EQ(t["child_frame_id"], ros2::CameraFrameId(c.id));
    const Eigen::Vector3d centre = c.Center();
    EXPECT_NEAR(t["transform"]["translation"]["x"].get<double>(), centre.x(), 1e-12);
    EXPECT_NEAR(t["transform"]["translation"]["z"].get<double>(), centre.z(), 1e-12);
    const json& q = t["transform"]["rotation"];
    const Eigen::Quaterniond rq(q["w"].get<double>(), q["x"].get<double>(), q["y"].get<double>(), q["z"].get<double>());
    EXPECT_TRUE(rq.toRotationMatrix().isApprox(c.cam_from_world.rotation.transpose(), 1e-12)) << k;
  }

  // The tracker's pose, and read back.
  const json& ps = decoded[4];
  EXPECT_EQ(ps["header"]["frame_id"], "hullpipe_world");
  EXPECT_DOUBLE_EQ(ps["pose"]["position"]["y"].get<double>(), 1.5);
  const Eigen::Quaterniond pq(
      ps["pose"]["orientation"]["w"].get<double>(), ps["pose"]["orientation"]["x"].get<double>(),
      ps["pose"]["orientation"]["y"].get<double>(), ps["pose"]["orientation"]["z"].get<double>());
  EXPECT_TRUE(pq.toRotationMatrix().isApprox(head.rotation, 1e-12));
  ros2::PoseCheck check;
  check.now_ns = stamp;
  const Rigid3d back = ros2::HeadFromPoseStamped(pose.msg, check);
  EXPECT_TRUE(back.rotation.isApprox(head.rotation, 1e-12));
  EXPECT_EQ(back.translation, head.translation);

  // A raw frame: bgr8, rows packed (step = 3 * width), bytes in order.
  const json& raw = decoded[5];
  EXPECT_EQ(raw["encoding"], "bgr8");
  EXPECT_EQ(raw["width"], 3);
  EXPECT_EQ(raw["height"], 2);
  EXPECT_EQ(raw["step"], 9);
  ASSERT_EQ(raw["data"].size(), 18u);
  for (int i = 0; i < 18; ++i) EXPECT_EQ(raw["data"][size_t(i)], 10 * i + 1) << i;
}

// A tracker's pose that is not one is refused naming the field: NaN, a
// quaternion far from unit, a frame hullpipe does not know, a stamp an hour
// off, nanoseconds past a second. Control: the same pose otherwise passes.
TEST(Ros2Pose, BadTrackerPosesAreRefusedNamingTheField) {
  const int64_t now = 5'000'000'000'000;
  ros2::PoseCheck check;
  check.now_ns = now;
  auto refused = [&](const geometry_msgs_msg_dds__PoseStamped_& m, const std::string& words) {
    try {
      ros2::HeadFromPoseStamped(m, check);
      ADD_FAILURE() << words << ": accepted";
    } catch (const dds::MessageError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  auto good = ros2::MakePoseStamped(Rigid3d{}, now + 20'000'000, ros2::kWorldFrame);
  EXPECT_NO_THROW(ros2::HeadFromPoseStamped(good.msg, check));
  auto m = good.msg;
  m.pose.position.x = std::nan("");
  refused(m, "pose.position");
  m = good.msg;
  m.pose.orientation.w = 2;
  refused(m, "pose.orientation");
  m = good.msg;
  m.pose.orientation.z = std::nan("");
  refused(m, "pose.orientation");
  auto elsewhere = ros2::MakePoseStamped(Rigid3d{}, now, "map");
  refused(elsewhere.msg, "header.frame_id 'map'");
  auto late = ros2::MakePoseStamped(Rigid3d{}, now - 3600'000'000'000, ros2::kWorldFrame);
  refused(late.msg, "header.stamp is -3600");
  m = good.msg;
  m.header.stamp.nanosec = 1'000'000'000;
  refused(m, "nanosec");
  m = good.msg;
  m.pose.position.z = 1e6;
  refused(m, "pose.position");
  // Time: negative nanoseconds split as ROS does (sec floor, nanosec in [0, 1e9)).
  const auto t = ros2::RosTime(-1);
  EXPECT_EQ(t.sec, -1);
  EXPECT_EQ(t.nanosec, 999'999'999u);
  EXPECT_EQ(ros2::NanosecondsOf(t), -1);
}

// A headset client's views on ROS 2 (ros2/hullpipe_msgs/msg/EyeViews.msg):
// two eyes 64 mm apart, turned and tilted, each with its own asymmetric
// XrFovf, as a ROS 2 peer nobody here wrote puts them on the wire (Foxglove's
// ROS 2 serializer from the .msg files, tests/js/encode_ros2.mjs). Cyclone
// reads those bytes as idl/ros2.idl's EyeViews_, and EyeViewsFromRos2 gives
// back each eye's pose in OpenCV's axes and its field of view exactly (the
// angles are dyadic, so float32 holds them). The bytes hullpipe's own
// MakeEyeViews makes of the same views are the same bytes: one wire form.
TEST_F(Ros2Messages, AHeadsetClientsEyeViewsFromFoxglovesWriterAreTheViewsRenderDraws) {
  EyeViewsSample want;
  want.tracker_id = 20;
  want.stamp_ns = 1'700'000'000'125'000'000;
  Rigid3d head;
  head.rotation = (Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
  head.translation = Eigen::Vector3d(0.25, -1.5, -1.75);
  for (size_t k = 0; k < 2; ++k) {
    want.world_from_eye[k].rotation = head.rotation;
    want.world_from_eye[k].translation = head.translation + head.rotation * Eigen::Vector3d(k ? 0.032 : -0.032, 0, 0);
  }
  want.fov[0] = EyeFov{-0.9375, 0.6875, 0.8125, -0.875};
  want.fov[1] = want.fov[0].Mirrored();
  // The client's message, field by field, as JSON for Foxglove's writer.
  json views = json::array();
  for (size_t k = 0; k < 2; ++k) {
    const Eigen::Vector3d& p = want.world_from_eye[k].translation;
    const Eigen::Vector4d q = XrOrientationOf(want.world_from_eye[k]);
    views.push_back({{"pose",
                      {{"position", {{"x", p.x()}, {"y", p.y()}, {"z", p.z()}}},
                       {"orientation", {{"x", q[0]}, {"y", q[1]}, {"z", q[2]}, {"w", q[3]}}}}},
                     {"angle_left", want.fov[k].left},
                     {"angle_right", want.fov[k].right},
                     {"angle_up", want.fov[k].up},
                     {"angle_down", want.fov[k].down}});
  }
  const json message = {
      {"header", {{"stamp", {{"sec", 1'700'000'000}, {"nanosec", 125'000'000}}}, {"frame_id", "hullpipe_world"}}},
      {"views", views}};
  const std::string in = (dir_ / "eye_views.txt").string(), out = (dir_ / "eye_views.hex").string();
  std::ofstream(in) << "hullpipe_msgs/msg/EyeViews " << message.dump() << "\n";
  test::Process node({"/usr/bin/env", "node", std::string(HULLPIPE_SOURCE_DIR) + "/tests/js/encode_ros2.mjs", in},
                     out, {}, out + ".err");
  ASSERT_EQ(node.Wait(60), 0) << test::ReadFile(out + ".err");
  std::string hex = test::ReadFile(out);
  while (!hex.empty() && std::isspace(static_cast<unsigned char>(hex.back()))) hex.pop_back();
  ASSERT_EQ(hex.rfind("error", 0), std::string::npos) << hex;
  std::vector<uint8_t> bytes;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) bytes.push_back(uint8_t(std::stoi(hex.substr(i, 2), nullptr, 16)));

  const dds::KnownType kt = ros2::Ros2KnownType("hullpipe_msgs/msg/EyeViews");
  const dds::CdrWriter cdr(*participant_, kt, kt.qos, dds::CdrWriter::Scope::kDecodeOnly);
  bool decoded = false;
  ASSERT_TRUE(cdr.DecodeWith<hullpipe_msgs_msg_dds__EyeViews_>(bytes, [&](const hullpipe_msgs_msg_dds__EyeViews_& m) {
    decoded = true;
    ros2::PoseCheck check;
    check.now_ns = want.stamp_ns + 5'000'000;
    const EyeViewsSample got = ros2::EyeViewsFromRos2(m, check, 20);
    EXPECT_EQ(got.tracker_id, 20u);
    EXPECT_EQ(got.stamp_ns, want.stamp_ns);
    for (size_t k = 0; k < 2; ++k) {
      SCOPED_TRACE(k ? "right eye" : "left eye");
      EXPECT_EQ(got.world_from_eye[k].translation, want.world_from_eye[k].translation);
      EXPECT_TRUE(got.world_from_eye[k].rotation.isApprox(want.world_from_eye[k].rotation, 1e-12));
      EXPECT_EQ(got.fov[k].left, want.fov[k].left);
      EXPECT_EQ(got.fov[k].right, want.fov[k].right);
      EXPECT_EQ(got.fov[k].up, want.fov[k].up);
      EXPECT_EQ(got.fov[k].down, want.fov[k].down);
    }
    // OpenXR's view axes became OpenCV's: the eye looks along the head's +z.
    EXPECT_TRUE((got.world_from_eye[0].rotation.col(2)).isApprox(head.rotation.col(2), 1e-12));
  }));
  EXPECT_TRUE(decoded);
  const auto ours = ros2::MakeEyeViews(want, ros2::kWorldFrame);
  EXPECT_EQ(Encode(kt, &ours.msg), bytes) << "hullpipe's bytes and Foxglove's differ";
}

// A headset client's views that are not views are refused naming the field
// and the eye: as a tracker's pose (frame, stamp, position, a quaternion far
// from unit), and a field of view that is not a frustum or not finite.
// Control: the same views otherwise pass.
TEST(Ros2Pose, BadEyeViewsAreRefusedNamingTheFieldAndTheEye) {
  const int64_t now = 5'000'000'000'000;
  ros2::PoseCheck check;
  check.now_ns = now;
  EyeViewsSample v;
  v.stamp_ns = now - 10'000'000;
  v.world_from_eye[1].translation = Eigen::Vector3d(0.064, 0, 0);
  v.fov[1] = v.fov[0].Mirrored();
  const auto good = ros2::MakeEyeViews(v, ros2::kWorldFrame);
  EXPECT_NO_THROW(ros2::EyeViewsFromRos2(good.msg, check, 3));
  auto refused = [&](const hullpipe_msgs_msg_dds__EyeViews_& m, const std::string& words) {
    try {
      ros2::EyeViewsFromRos2(m, check, 3);
      ADD_FAILURE() << words << ": accepted";
    } catch (const dds::MessageError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  auto m = good.msg;
  m.views[1].pose.position.y = std::nan("");
  refused(m, "EyeViews: views[1].pose.position");
  m = good.msg;
  m.views[0].pose.orientation = {0, 0, 0, 0};
  refused(m, "EyeViews: views[0].pose.orientation");
  m = good.msg;
  m.views[1].pose.orientation.w += 0.5;
  refused(m, "views[1].pose.orientation");
  m = good.msg;
  m.views[1].angle_left = 0.5f, m.views[1].angle_right = -0.5f;
  refused(m, "views[1] field of view");
  m = good.msg;
  m.views[0].angle_up = std::nanf("");
  refused(m, "views[0] field of view");
  m = good.msg;
  m.views[0].angle_down = -1.6f;  // past 89 degrees
  refused(m, "views[0] field of view");
  const auto elsewhere = ros2::MakeEyeViews(v, "map");
  refused(elsewhere.msg, "EyeViews: header.frame_id 'map'");
  v.stamp_ns = now - 3600'000'000'000;
  const auto late = ros2::MakeEyeViews(v, ros2::kWorldFrame);
  refused(late.msg, "EyeViews: header.stamp is -3600");
}

// hullpipe_ros2 beside a pipeline: a camera's calibration, map and JPEG frame
// come out as ROS 2 topics a plain ROS 2 peer reads (rmw_cyclonedds' names and
// types), /tf_static reaches a reader that joins late, and a tracker's
// PoseStamped becomes the HeadPose render_node follows; a NaN pose is refused,
// named once however often it comes, and counted, while the good pose that
// follows it passes (the positive control). Stops within a second of SIGINT.
TEST(Ros2Process, PublishesTheRigAsRos2TopicsAndFollowsATracker) {
  const auto dir = test::TempDir("ros2_process");
  const std::string config = test::WriteLoopbackConfig(dir), log = (dir / "ros2.log").string();
  setenv("CYCLONEDDS_URI", ("file://" + config).c_str(), 1);
  const uint32_t domain = test::UniqueDomain();
  auto bridge = test::StartExe("hullpipe_ros2", {}, domain, config, log);
  dds::Participant p(domain);
  // The pipeline's side: camera 1's calibration (transient-local), then maps and frames.
  Camera cam = RingCameras(1, 3, 2, Eigen::Vector3d::Zero(), 64, 48, 1.0, Distortion{})[0];
  cam.id = 1;
  dds::Writer<hullpipe_msg_CameraInfo> infos(p);
  infos.Write(dds::CameraToMsg(cam, {}));
  dds::Writer<hullpipe_msg_ObjectPixelMap> maps(p);
  dds::Writer<hullpipe_msg_CameraImage> images(p);
  cv::Mat map(48, 64, CV_8UC1, cv::Scalar(0));
  map(cv::Rect(8, 4, 16, 12)).setTo(255);
  // The ROS 2 side, as a ROS 2 node would subscribe.
  dds::Reader<sensor_msgs_msg_dds__CameraInfo_> ros_info(p, "rt/hullpipe/cam1/camera_info", ros2::kDefaultQos);
  dds::Reader<sensor_msgs_msg_dds__Image_> ros_map(p, "rt/hullpipe/cam1/object_pixel_map", ros2::kDefaultQos);
  dds::Reader<sensor_msgs_msg_dds__CompressedImage_> ros_image(p, "rt/hullpipe/cam1/image/compressed",
                                                               ros2::kDefaultQos);
  dds::Reader<sensor_msgs_msg_dds__Image_> ros_raw(p, "rt/hullpipe/cam1/image", ros2::kDefaultQos);
  bool got_info = false, got_map = false, got_image = false, got_raw = false;
  int64_t info_stamp = 0;
  uint32_t map_bytes_on = 0;
  const int64_t t0 = 1'700'000'000'000'000'000;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  for (uint64_t seq = 1; !(got_info && got_map && got_image && got_raw) && std::chrono::steady_clock::now() < deadline;
       ++seq) {
    const int64_t t = t0 + int64_t(seq) * 40'000'000;
    maps.Write(dds::MakeMapMessage({1, seq, t, 0.04 * double(seq)}, 1, map).msg);
    // JPEG and raw frames by turns (a camera sends one or the other).
    images.Write(
        dds::MakeImageMessage(1, seq, t, cv::Mat(48, 64, CV_8UC3, cv::Scalar(1, 2, 3)), seq % 2 ? 80 : 0).msg);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    ros_info.TakeEach([&](const sensor_msgs_msg_dds__CameraInfo_& m, const dds_sample_info_t&) {
      got_info = true;
      info_stamp = ros2::NanosecondsOf(m.header.stamp);
      EXPECT_STREQ(m.header.frame_id, "hullpipe_cam1");
      EXPECT_DOUBLE_EQ(m.k[2], cam.cx - 0.5);
    });
    ros_map.TakeEach([&](const sensor_msgs_msg_dds__Image_& m, const dds_sample_info_t&) {
      got_map = true;
      EXPECT_STREQ(m.encoding, "mono8");
      map_bytes_on = 0;
      for (uint32_t i = 0; i < m.data._length; ++i) map_bytes_on += m.data._buffer[i] == 255;
    });
    ros_image.TakeEach([&](const sensor_msgs_msg_dds__CompressedImage_& m, const dds_sample_info_t&) {
      got_image = true;
      EXPECT_STREQ(m.format, "jpeg");
      ASSERT_GT(m.data._length, 2u);
      EXPECT_EQ(m.data._buffer[0], 0xFF);  // a JPEG's SOI
      EXPECT_EQ(m.data._buffer[1], 0xD8);
    });
    ros_raw.TakeEach([&](const sensor_msgs_msg_dds__Image_& m, const dds_sample_info_t&) {
      got_raw = true;
      EXPECT_STREQ(m.encoding, "bgr8");
      ASSERT_EQ(m.data._length, 64u * 48u * 3u);
      EXPECT_EQ(m.data._buffer[0], 1);  // B G R as captured
      EXPECT_EQ(m.data._buffer[2], 3);
    });
  }
  ASSERT_TRUE(got_info && got_map && got_image && got_raw) << test::ReadFile(log);
  EXPECT_GT(info_stamp, t0);  // the capture time, not the wall clock
  EXPECT_EQ(map_bytes_on, 16u * 12u);

  // The node on ros_discovery_info (transient-local): named, its gid the
  // participant's GUID and its writers' gids the GUIDs Cyclone's own discovery
  // reports for the rt/ writers (DCPSPublication), as rmw_cyclonedds makes them.
  {
    dds::Reader<rmw_dds_common_msg_dds__ParticipantEntitiesInfo_> discovery(p, "ros_discovery_info",
                                                                            ros2::kDiscoveryQos);
    dds::Entity publications(dds_create_reader(p.handle(), DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr));
    std::set<std::string> rt_writers;  // GUIDs of the bridge's rt/ writers, as bytes
    std::string participant_guid, info_gid;
    std::set<std::string> info_writers;
    std::string node_name;
    auto guid = [](const void* bytes) { return std::string(static_cast<const char*>(bytes), 16); };
    for (auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
         std::chrono::steady_clock::now() < until;) {
      void* samples[16] = {nullptr};
      dds_sample_info_t si[16];
      const int32_t n = dds_take(publications.handle(), samples, si, 16, 16);
      for (int32_t i = 0; i < n; ++i) {
        const auto* ep = static_cast<const dds_builtintopic_endpoint_t*>(samples[i]);
        if (si[i].valid_data && ep->topic_name && std::string(ep->topic_name).rfind("rt/hullpipe/cam1/", 0) == 0) {
          rt_writers.insert(guid(ep->key.v));
          participant_guid = guid(ep->participant_key.v);
        }
      }
      if (n > 0) dds_return_loan(publications.handle(), samples, n);
      discovery.TakeEach([&](const rmw_dds_common_msg_dds__ParticipantEntitiesInfo_& m, const dds_sample_info_t&) {
        info_gid = guid(m.gid.data);
        EXPECT_EQ(std::count(m.gid.data + 16, m.gid.data + 24, 0), 8) << "zero-padded";
        ASSERT_EQ(m.node_entities_info_seq._length, 1u);
        const auto& node = m.node_entities_info_seq._buffer[0];
        node_name = node.node_name;
        EXPECT_STREQ(node.node_namespace, "/");
        info_writers.clear();
        for (uint32_t k = 0; k < node.writer_gid_seq._length; ++k)
          info_writers.insert(guid(node.writer_gid_seq._buffer[k].data));
        EXPECT_EQ(node.reader_gid_seq._length, 2u);  // the tracker's PoseStamped, the headset's EyeViews
      });
      if (rt_writers.size() >= 3 && !info_gid.empty() &&
          std::includes(info_writers.begin(), info_writers.end(), rt_writers.begin(), rt_writers.end()))
        break;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    EXPECT_EQ(node_name, "hullpipe_ros2");
    EXPECT_GE(rt_writers.size(), 3u);  // camera_info, object_pixel_map, image(s)
    EXPECT_TRUE(std::includes(info_writers.begin(), info_writers.end(), rt_writers.begin(), rt_writers.end()))
        << rt_writers.size() << " rt/ writers, " << info_writers.size() << " named";
    EXPECT_EQ(info_gid, participant_guid);
  }

  // /tf_static is transient-local: a reader that joins now still gets it.
  dds::Reader<tf2_msgs_msg_dds__TFMessage_> tf(p, "rt/tf_static", ros2::kTfStaticQos);
  bool got_tf = false;
  for (auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
       !got_tf && std::chrono::steady_clock::now() < until;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    tf.TakeEach([&](const tf2_msgs_msg_dds__TFMessage_& m, const dds_sample_info_t&) {
      got_tf = true;
      ASSERT_EQ(m.transforms._length, 1u);
      EXPECT_STREQ(m.transforms._buffer[0].child_frame_id, "hullpipe_cam1");
      EXPECT_NEAR(m.transforms._buffer[0].transform.translation.x, cam.Center().x(), 1e-12);
    });
  }
  EXPECT_TRUE(got_tf);

  // A tracker: NaN poses until the bridge says it refused one, then a good one.
  dds::Writer<geometry_msgs_msg_dds__PoseStamped_> tracker(p, "rt/hullpipe/head_pose", ros2::kDefaultQos);
  dds::Reader<hullpipe_msg_HeadPose> heads(p);
  Rigid3d head;
  head.translation = Eigen::Vector3d(0.3, -0.2, -1.6);
  head.rotation = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()).toRotationMatrix();
  int nan_sent = 0;
  for (auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
       (nan_sent < 3 || test::ReadFile(log).find("refused") == std::string::npos) &&
       std::chrono::steady_clock::now() < until;) {
    auto bad = ros2::MakePoseStamped(head, std::chrono::duration_cast<std::chrono::nanoseconds>(
                                               std::chrono::system_clock::now().time_since_epoch())
                                               .count(),
                                     ros2::kWorldFrame);
    bad.msg.pose.position.x = std::nan("");
    tracker.Write(bad.msg);
    ++nan_sent;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  bool got_head = false;
  for (auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
       !got_head && std::chrono::steady_clock::now() < until;) {
    const auto good = ros2::MakePoseStamped(head, std::chrono::duration_cast<std::chrono::nanoseconds>(
                                                      std::chrono::system_clock::now().time_since_epoch())
                                                      .count(),
                                            ros2::kWorldFrame);
    tracker.Write(good.msg);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    heads.TakeEach([&](const hullpipe_msg_HeadPose& m, const dds_sample_info_t&) {
      const Rigid3d got = dds::HeadPoseFromMsg(m);
      ASSERT_TRUE(got.translation.allFinite()) << "a NaN pose was passed on";
      EXPECT_TRUE(got.translation.isApprox(head.translation, 1e-12));
      EXPECT_TRUE(got.rotation.isApprox(head.rotation, 1e-12));
      got_head = true;
    });
  }
  EXPECT_TRUE(got_head) << test::ReadFile(log);
  const auto stop = std::chrono::steady_clock::now();
  EXPECT_EQ(bridge->Stop(10), 0);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - stop).count(), 1.0 * test::TimeScale());
  const std::string text = test::ReadFile(log);
  size_t said = 0;
  for (size_t at = text.find("tracker pose"); at != std::string::npos; at = text.find("tracker pose", at + 1)) ++said;
  EXPECT_EQ(said, 1u) << nan_sent << " NaN poses sent:\n" << text;
  // The end line counts every refusal: each NaN pose that reached it (a
  // best-effort reader of depth 1 may miss some, never all but the last).
  const size_t at = text.find(" poses passed on, ");
  ASSERT_NE(at, std::string::npos) << text;
  const int refused = std::atoi(text.c_str() + at + std::strlen(" poses passed on, "));
  EXPECT_GE(refused, 1) << text;
  EXPECT_LE(refused, nan_sent) << text;
}

// The paper's head-mounted camera, tracked by a ROS 2 tracker: the rig says
// camera 2 is `tracked: topic`, hullpipe_ros2 passes the tracker's PoseStamped
// on as CameraPose (--camera-pose 2=/lab/hmd_camera), and capture_node poses
// each of camera 2's frames by it. Before the tracker sends, camera 2's frames
// are held back (named, counted: no map on the domain, the absence); once it
// sends, each map carries the tracker's pose (the positive control).
TEST(Ros2Process, ATrackersPoseStampedPosesTheHeadMountedCamerasFrames) {
  if (!test::HaveRig()) GTEST_SKIP() << "no rig at " << test::RigDir();
  const auto dir = test::TempDir("ros2_camera_pose");
  const std::string config = test::WriteLoopbackConfig(dir), log = (dir / "ros2.log").string(),
                    capture_log = (dir / "capture.log").string();
  setenv("CYCLONEDDS_URI", ("file://" + config).c_str(), 1);
  const uint32_t domain = test::UniqueDomain();
  Rig rig = LoadRig(test::RigDir());
  Camera calibrated;
  for (auto& rc : rig.cameras)
    if (rc.camera.id == 2) rc.tracked = RigCamera::kTrackedByTopic, calibrated = rc.camera;
  const std::string rig_file = (dir / "tracked.yaml").string();
  WriteRigYaml(rig, rig_file);
  dds::Participant p(domain);
  dds::Reader<hullpipe_msg_ObjectPixelMap> maps(p);
  auto capture = test::StartExe("capture_node", {"--rig", rig_file, "--cameras", "2", "--loop", "--fps", "25"}, domain,
                                config, capture_log);
  auto bridge = test::StartExe("hullpipe_ros2",
                               {"--head-pose-topic", "", "--camera-pose", "2=/lab/hmd_camera", "--no-maps",
                                "--no-images"},
                               domain, config, log);
  // No pose yet: camera 2's frames are held back, said once.
  int early_maps = 0;
  for (auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
       test::ReadFile(capture_log).find("no CameraPose within") == std::string::npos &&
       std::chrono::steady_clock::now() < until;)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_NE(test::ReadFile(capture_log).find("no CameraPose within"), std::string::npos) << test::ReadFile(capture_log);
  early_maps += int(maps.TakeEach([](const hullpipe_msg_ObjectPixelMap&, const dds_sample_info_t&) {}));
  EXPECT_EQ(early_maps, 0) << "a frame of the tracked camera went out unposed";
  // The tracker: the camera 0.25 m along world x from its calibration, turned
  // 0.1 rad about its own y axis, at 100 Hz, stamped now.
  const Rigid3d calibrated_world = calibrated.cam_from_world.Inverse();
  Rigid3d tracked_world;
  tracked_world.rotation =
      calibrated_world.rotation * Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()).toRotationMatrix();
  tracked_world.translation = calibrated_world.translation + Eigen::Vector3d(0.25, 0, 0);
  dds::Writer<geometry_msgs_msg_dds__PoseStamped_> tracker(p, "rt/lab/hmd_camera", ros2::kDefaultQos);
  int posed = 0;
  for (auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
       posed < 5 && std::chrono::steady_clock::now() < until;) {
    const int64_t now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                            std::chrono::system_clock::now().time_since_epoch())
                            .count();
    tracker.Write(ros2::MakePoseStamped(tracked_world, now, ros2::kWorldFrame).msg);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    maps.TakeEach([&](const hullpipe_msg_ObjectPixelMap& m, const dds_sample_info_t&) {
      ASSERT_EQ(m.camera_id, 2u);
      const auto pose = dds::MapPoseFromMsg(m);
      ASSERT_TRUE(pose) << "a map of the tracked camera without its pose";
      // One pose all along: interpolating between its samples gives it back
      // (to rounding: the quaternion's slerp, the ROS message's doubles).
      EXPECT_LT((pose->Inverse().translation - tracked_world.translation).norm(), 1e-9);
      EXPECT_LT((pose->Inverse().rotation - tracked_world.rotation).norm(), 1e-9);
      ++posed;
    });
  }
  EXPECT_GE(posed, 5) << test::ReadFile(log) << test::ReadFile(capture_log);
  EXPECT_EQ(bridge->Stop(10), 0);
  EXPECT_EQ(capture->Stop(10), 0);
  const std::string text = test::ReadFile(log);
  EXPECT_NE(text.find(" camera poses passed on"), std::string::npos) << text;
  EXPECT_EQ(text.find(" 0 camera poses passed on"), std::string::npos) << text;
}

// A tracker that broadcasts its frame on /tf drives the view (--head-frame),
// and another frame poses the head-mounted camera (--camera-frame): in a
// message of 1500 transforms (a flood) the frames among the first 1000 are
// found and passed on, the rest counted and named once; the same frames under
// another parent are refused naming the field.
TEST(Ros2Process, ATfFrameDrivesTheViewAndAFloodOfFramesIsBounded) {
  const auto dir = test::TempDir("ros2_tf");
  const std::string config = test::WriteLoopbackConfig(dir), log = (dir / "ros2.log").string();
  setenv("CYCLONEDDS_URI", ("file://" + config).c_str(), 1);
  const uint32_t domain = test::UniqueDomain();
  auto bridge = test::StartExe(
      "hullpipe_ros2", {"--head-pose-topic", "", "--head-frame", "tracker_head", "--camera-frame", "3=hmd_camera"},
      domain, config, log);
  dds::Participant p(domain);
  dds::Writer<tf2_msgs_msg_dds__TFMessage_> tf(p, "rt/tf", ros2::kDefaultQos);
  dds::Reader<hullpipe_msg_HeadPose> heads(p);
  dds::Reader<hullpipe_msg_CameraPose> camera_poses(p);
  const auto now = [] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
        .count();
  };
  // 1500 frames; the head's (index 700) 1.25 m up, turned about z; the
  // head-mounted camera's (index 900, --camera-frame) 0.5 m along x.
  auto flood = [&](const char* parent) {
    Camera c;  // MakeCameraTransforms gives world -> camera frames; renamed below
    std::vector<Camera> cams(1500, c);
    for (int i = 0; i < 1500; ++i) cams[size_t(i)].id = i;
    auto msg = ros2::MakeCameraTransforms(cams, now());
    std::vector<std::string> names = {"tracker_head", parent, "hmd_camera"};
    auto& ours = msg.transforms[700];
    ours.child_frame_id = const_cast<char*>(names[0].c_str());
    ours.header.frame_id = const_cast<char*>(names[1].c_str());
    ours.transform.translation = {0.1, 0.2, 1.25};
    ours.transform.rotation = {0, 0, std::sin(0.2), std::cos(0.2)};
    auto& camera = msg.transforms[900];
    camera.child_frame_id = const_cast<char*>(names[2].c_str());
    camera.header.frame_id = const_cast<char*>(names[1].c_str());
    camera.transform.translation = {0.5, 0, 1.0};
    camera.transform.rotation = {0, 0, 0, 1};
    tf.Write(msg.msg);
  };
  bool got = false, got_camera = false;
  for (auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
       !(got && got_camera) && std::chrono::steady_clock::now() < until;) {
    flood(ros2::kWorldFrame);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    heads.TakeEach([&](const hullpipe_msg_HeadPose& m, const dds_sample_info_t&) {
      const Rigid3d h = dds::HeadPoseFromMsg(m);
      EXPECT_NEAR(h.translation.z(), 1.25, 1e-12);
      EXPECT_TRUE(h.rotation.isApprox(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()).toRotationMatrix(), 1e-12));
      got = true;
    });
    camera_poses.TakeEach([&](const hullpipe_msg_CameraPose& m, const dds_sample_info_t&) {
      EXPECT_EQ(m.camera_id, 3u);
      const Rigid3d c = dds::CameraPoseFromMsg(m);
      EXPECT_NEAR(c.translation.x(), 0.5, 1e-12);
      EXPECT_TRUE(c.rotation.isIdentity(1e-12));
      got_camera = true;
    });
  }
  EXPECT_TRUE(got) << test::ReadFile(log);
  EXPECT_TRUE(got_camera) << test::ReadFile(log);
  // The same frame under a parent hullpipe does not look up: refused, said.
  for (auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
       test::ReadFile(log).find("header.frame_id 'map'") == std::string::npos &&
       std::chrono::steady_clock::now() < until;) {
    flood("map");
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(bridge->Stop(10), 0);
  const std::string text = test::ReadFile(log);
  EXPECT_NE(text.find("header.frame_id 'map'"), std::string::npos) << text;
  size_t said = 0;
  for (size_t at = text.find("a /tf message of 1500"); at != std::string::npos;
       at = text.find("a /tf message of 1500", at + 1))
    ++said;
  EXPECT_EQ(said, 1u) << text;
  EXPECT_NE(text.find("tf transforms past the bound"), std::string::npos) << text;
  EXPECT_EQ(text.find(" 0 tf transforms past the bound"), std::string::npos) << text;
}

// `hullpipe_record export --ros2`: a recording of a camera's calibration, map
// and frames becomes an MCAP file as rosbag2 writes one (profile ros2,
// schemas ros2msg, messages cdr, offered_qos_profiles), which @mcap/core reads
// and Foxglove's ROS 2 parser and decoder decode in full, field by field.
// A codec of hullpipe type `type` that publishes nothing (samples for a recording).
std::unique_ptr<dds::CdrWriter> DecodeOnlyCodec(const dds::Participant& p, const char* type) {
  const dds::KnownType& kt = *dds::FindKnownType(type);
  return std::make_unique<dds::CdrWriter>(p, kt, kt.qos, dds::CdrWriter::Scope::kDecodeOnly);
}

TEST(Ros2Export, TheRecordingAsARosbag2McapOpensInFoxglovesRos2Reader) {
  const auto dir = test::TempDir("ros2_export");
  setenv("CYCLONEDDS_URI", ("file://" + test::WriteLoopbackConfig(dir)).c_str(), 1);
  const uint32_t domain = test::UniqueDomain();
  const std::string rec = (dir / "run.hprec").string();
  Camera cam = RingCameras(1, 3, 2, Eigen::Vector3d::Zero(), 64, 48, 1.0, Distortion{})[0];
  cam.id = 2;
  cv::Mat map(48, 64, CV_8UC1, cv::Scalar(0));
  map(cv::Rect(4, 4, 10, 6)).setTo(255);
  const int64_t t0 = 1'700'000'000'000'000'000;
  {
    dds::Participant p(domain);
    auto codec = [&](const char* type) { return DecodeOnlyCodec(p, type); };
    auto info_codec = codec("hullpipe::msg::CameraInfo"), map_codec = codec("hullpipe::msg::ObjectPixelMap"),
         image_codec = codec("hullpipe::msg::CameraImage"), state_codec = codec("hullpipe::msg::VirtualObjectState"),
         report_codec = codec("hullpipe::msg::CollisionReport"), mesh_codec = codec("hullpipe::msg::VirtualMesh");
    record::RecordingWriter w(rec);
    const int64_t ti = w.AddTopic({0, "hullpipe/camera_info", "hullpipe::msg::CameraInfo", true, true, true, 1, ""});
    const int64_t tm =
        w.AddTopic({0, "hullpipe/object_pixel_map", "hullpipe::msg::ObjectPixelMap", true, true, false, 4, ""});
    const int64_t tc = w.AddTopic({0, "hullpipe/camera_image", "hullpipe::msg::CameraImage", true, true, false, 4, ""});
    const hullpipe_msg_CameraInfo info = dds::CameraToMsg(cam, {});
    w.Append({ti, t0, t0, info_codec->Encode(&info)});
    for (uint64_t k = 1; k <= 3; ++k) {
      const int64_t t = t0 + int64_t(k) * 40'000'000;
      const auto m = dds::MakeMapMessage({2, k, t, 0.04 * double(k)}, 1, map);
      w.Append({tm, t + 1000, t, map_codec->Encode(&m.msg)});
      const auto img = dds::MakeImageMessage(2, k, t, cv::Mat(48, 64, CV_8UC3, cv::Scalar(5, 6, 7)), k == 2 ? 0 : 80);
      w.Append({tc, t + 2000, t, image_codec->Encode(&img.msg)});
    }
    // sim_node's: a ball (colliding, with its collision points), a box, a curtain.
    const int64_t ts =
        w.AddTopic({0, "hullpipe/object_state", "hullpipe::msg::VirtualObjectState", true, true, false, 1, ""});
    const int64_t tr =
        w.AddTopic({0, "hullpipe/collision_report", "hullpipe::msg::CollisionReport", true, true, false, 16, ""});
    const int64_t tv = w.AddTopic({0, "hullpipe/virtual_mesh", "hullpipe::msg::VirtualMesh", true, true, false, 1, ""});
    VirtualObjectSample ball;
    ball.object_id = 1, ball.radius = 0.1, ball.position = {0.2, 0.3, -1}, ball.colliding = true;
    ball.capture_time_ns = t0 + 40'000'000;
    const hullpipe_msg_VirtualObjectState ball_msg = dds::VirtualObjectToMsg(ball);
    w.Append({ts, t0 + 50'000'000, ball.capture_time_ns, state_codec->Encode(&ball_msg)});
    VirtualObjectSample box = ball;
    box.object_id = 2, box.shape = VirtualObjectSample::Shape::kBox, box.half_extents = {0.1, 0.2, 0.3};
    box.colliding = false;
    const hullpipe_msg_VirtualObjectState box_msg = dds::VirtualObjectToMsg(box);
    w.Append({ts, t0 + 50'000'001, ball.capture_time_ns, state_codec->Encode(&box_msg)});
    CollisionReportSample report;
    report.object_id = 1, report.capture_time_ns = ball.capture_time_ns;
    report.triangle_ids = {4};
    report.collision_points = {{0.1, 0.3, -1}, {0.12, 0.31, -1}};
    const auto report_msg = dds::MakeCollisionReportMessage(report);
    w.Append({tr, t0 + 50'000'002, ball.capture_time_ns, report_codec->Encode(&report_msg.msg)});
    VirtualMeshSample curtain;
    curtain.object_id = 100, curtain.kind = kMeshCloth, curtain.element = "cloth";
    curtain.capture_time_ns = ball.capture_time_ns;
    curtain.draw.vertices = {{0, 0, -1}, {0.1, 0, -1}, {0, 0.1, -1}, {0.1, 0.1, -1}};
    curtain.draw.triangles = {{0, 1, 2}, {1, 3, 2}};
    curtain.draw.colliding = {0, 1};
    const auto mesh_msg = dds::MakeVirtualMeshMessage(curtain);
    w.Append({tv, t0 + 50'000'003, ball.capture_time_ns, mesh_codec->Encode(&mesh_msg.msg)});
    // A CAD model's one part, sent once, and its state after two steps.
    auto part_codec = codec("hullpipe::msg::ModelPart"), model_codec = codec("hullpipe::msg::ModelState");
    const int64_t tp = w.AddTopic({0, "hullpipe/model_part", "hullpipe::msg::ModelPart", true, true, true, 1, ""});
    const int64_t tq = w.AddTopic({0, "hullpipe/model_state", "hullpipe::msg::ModelState", true, true, false, 2, ""});
    ModelPartSample part;
    part.object_id = 300, part.model_id = 300, part.name = "block", part.file = "block.obj";
    part.vertices = {{0, 0, 0}, {0.2f, 0, 0}, {0, 0.2f, 0}};
    part.triangles = {{0, 1, 2}};
    const auto part_msg = dds::MakeModelPartMessage(part);
    w.Append({tp, t0 + 1, t0, part_codec->Encode(&part_msg.msg)});
    ModelStateSample model;
    model.model_id = 300, model.parts.resize(1);
    for (int k = 1; k <= 2; ++k) {
      model.capture_time_ns = t0 + k * 40'000'000;
      model.parts[0].position = {0.1 * k, 0, -1};
      const auto model_msg = dds::MakeModelStateMessage(model);
      w.Append({tq, model.capture_time_ns + 5, model.capture_time_ns, model_codec->Encode(&model_msg.msg)});
    }
  }
  const std::string out = (dir / "export").string(), log = (dir / "export.log").string();
  test::Process exp({test::BinDir() + "/hullpipe_record", "export", rec, "-o", out, "--ros2", "--no-media",
                     "--domain", std::to_string(domain)},
                    log);
  ASSERT_EQ(exp.Wait(120), 0) << test::ReadFile(log);
  // The model's topics export as JSON lines too (every sample decoded: exit 0).
  const json part_line = json::parse(test::ReadFile(out + "/hullpipe_model_part.jsonl"));
  EXPECT_EQ(part_line["name"], "block");
  EXPECT_EQ(part_line["triangles"], 1);
  std::ifstream state_lines(out + "/hullpipe_model_state.jsonl");
  std::string state_line;
  ASSERT_TRUE(std::getline(state_lines, state_line));
  EXPECT_DOUBLE_EQ(json::parse(state_line)["parts"][0]["position"][0].get<double>(), 0.1);
  const std::string js = std::string(HULLPIPE_SOURCE_DIR) + "/tests/js", node_out = (dir / "ros2.json").string();
  test::Process node({"/usr/bin/env", "node", js + "/read_ros2_mcap.mjs", out + "/ros2.mcap"}, node_out, {},
                     node_out + ".err");
  ASSERT_EQ(node.Wait(120), 0) << test::ReadFile(node_out + ".err");
  const json j = json::parse(test::ReadFile(node_out));
  EXPECT_EQ(j["profile"], "ros2");
  EXPECT_TRUE(j["invalid"].empty()) << j["invalid"].dump();
  const json& ch = j["channels"];
  const std::map<std::string, std::pair<std::string, int>> want = {
      {"/tf_static", {"tf2_msgs/msg/TFMessage", 1}},
      {"/hullpipe/cam2/camera_info", {"sensor_msgs/msg/CameraInfo", 3}},
      {"/hullpipe/cam2/object_pixel_map", {"sensor_msgs/msg/Image", 3}},
      {"/hullpipe/cam2/image/compressed", {"sensor_msgs/msg/CompressedImage", 2}},
      {"/hullpipe/cam2/image", {"sensor_msgs/msg/Image", 1}},
      {"/hullpipe/markers", {"visualization_msgs/msg/MarkerArray", 4}},
      {"/hullpipe/collisions", {"hullpipe_msgs/msg/CollisionReport", 1}},
      {"/hullpipe/model_markers", {"visualization_msgs/msg/MarkerArray", 1}},
      {"/tf", {"tf2_msgs/msg/TFMessage", 2}}};
  EXPECT_EQ(ch.size(), want.size()) << ch.dump(1);
  for (const auto& [topic, w] : want) {
    ASSERT_TRUE(ch.contains(topic)) << topic << " " << ch.dump(1);
    const json& c = ch[topic];
    EXPECT_EQ(c["schema"], w.first) << topic;
    EXPECT_EQ(c["schemaEncoding"], "ros2msg") << topic;
    EXPECT_EQ(c["messageEncoding"], "cdr") << topic;
    EXPECT_EQ(c["count"], w.second) << topic;
    EXPECT_EQ(c["decoded"], w.second) << topic;
    // rosbag2's QoS metadata, as ros2 bag play offers it again.
    const std::string qos = c["metadata"].value("offered_qos_profiles", "");
    EXPECT_NE(qos.find("reliability: 1"), std::string::npos) << topic << ": " << qos;
    const bool latched = topic == "/tf_static" || topic == "/hullpipe/model_markers";
    EXPECT_NE(qos.find(latched ? "durability: 1" : "durability: 2"), std::string::npos) << topic << ": " << qos;
  }
  const json& first = j["first"];
  EXPECT_EQ(first["/hullpipe/cam2/camera_info"]["header"]["frame_id"], "hullpipe_cam2");
  EXPECT_EQ(first["/hullpipe/cam2/camera_info"]["header"]["stamp"]["sec"], 1'700'000'000);
  EXPECT_EQ(first["/hullpipe/cam2/camera_info"]["header"]["stamp"]["nanosec"],
            40'000'000);  // the first map's capture time
  EXPECT_DOUBLE_EQ(first["/hullpipe/cam2/camera_info"]["k"][2].get<double>(), cam.cx - 0.5);
  EXPECT_EQ(first["/hullpipe/cam2/object_pixel_map"]["encoding"], "mono8");
  EXPECT_EQ(first["/hullpipe/cam2/object_pixel_map"]["data"]["length"], 64 * 48);
  EXPECT_EQ(first["/hullpipe/cam2/image"]["encoding"], "bgr8");
  EXPECT_EQ(first["/hullpipe/cam2/image/compressed"]["format"], "jpeg");
  EXPECT_EQ(first["/tf_static"]["transforms"][0]["child_frame_id"], "hullpipe_cam2");
  // The collision report with hullpipe_msgs' schema from the bag itself; the
  // model's part in its own frame, posed on /tf.
  EXPECT_EQ(first["/hullpipe/collisions"]["object_id"], 1);
  EXPECT_EQ(first["/hullpipe/collisions"]["triangle_ids"], json::array({4}));
  EXPECT_DOUBLE_EQ(first["/hullpipe/collisions"]["collision_points"][1]["x"].get<double>(), 0.12);
  EXPECT_EQ(first["/hullpipe/model_markers"]["markers"][0]["header"]["frame_id"], "hullpipe_part300");
  EXPECT_EQ(first["/hullpipe/model_markers"]["markers"][0]["points"].size(), 3u);
  EXPECT_EQ(first["/tf"]["transforms"][0]["child_frame_id"], "hullpipe_part300");
  EXPECT_DOUBLE_EQ(first["/tf"]["transforms"][0]["transform"]["translation"]["x"].get<double>(), 0.1);
  // The first marker: the colliding ball, a red sphere of its diameter.
  const json& ball_marker = first["/hullpipe/markers"]["markers"][0];
  EXPECT_EQ(ball_marker["ns"], "hullpipe_objects");
  EXPECT_EQ(ball_marker["type"], 2);  // SPHERE
  EXPECT_DOUBLE_EQ(ball_marker["scale"]["x"].get<double>(), 0.2);
  EXPECT_NEAR(ball_marker["color"]["r"].get<double>(), 0.9, 1e-6);
  EXPECT_DOUBLE_EQ(ball_marker["pose"]["position"]["z"].get<double>(), -1.0);
}

// A headset's two eyes downstream (render_node --stereo; docs/hmd.md, "Both eyes
// downstream"): a stereo run's recording exported as a ROS 2 bag and for
// Foxglove gives each eye its own frame and topic, read by Foxglove's readers:
// /tf's hullpipe_view_left and hullpipe_view_right, each eye's composite on its
// own image topic in its eye's frame, one hull cloud per frameset (the left
// eye's). The views of a recording made before the eye field (4 bytes shorter)
// are the one view, on the topics they always had.
TEST(Ros2Export, AHeadsetsEyesEachGetTheirOwnFrameAndTopic) {
  const auto dir = test::TempDir("ros2_export_eyes");
  setenv("CYCLONEDDS_URI", ("file://" + test::WriteLoopbackConfig(dir)).c_str(), 1);
  const uint32_t domain = test::UniqueDomain();
  const std::string rec = (dir / "run.hprec").string();
  StereoOptions so;
  so.width = 32, so.height = 24;
  const Rigid3d head = LookAt({0, -2, -1}, {0, 0, -1}, {0, 0, -1});
  const StereoViews eyes = MakeStereoViews(head, so);
  const int64_t t0 = 1'700'000'000'000'000'000;
  {
    dds::Participant p(domain);
    auto codec = [&](const char* type) { return DecodeOnlyCodec(p, type); };
    auto pose_codec = codec("hullpipe::msg::ViewPose"), tile_codec = codec("hullpipe::msg::HullView"),
         view_codec = codec("hullpipe::msg::CompositedView");
    record::RecordingWriter w(rec);
    const int64_t tp = w.AddTopic({0, "hullpipe/view_pose", "hullpipe::msg::ViewPose", true, false, false, 4, ""});
    const int64_t th = w.AddTopic({0, "hullpipe/hull_view", "hullpipe::msg::HullView", true, false, false, 4, ""});
    const int64_t tc =
        w.AddTopic({0, "hullpipe/composited_view", "hullpipe::msg::CompositedView", false, false, false, 1, ""});
    // The earlier layout: the body less the eye and its padding, no padding declared.
    const auto earlier = [](std::vector<uint8_t> cdr) {
      cdr.resize(cdr.size() - 4);
      cdr[3] = 0;
      return cdr;
    };
    const auto add = [&](uint64_t pose_seq, const NovelView& v, ViewEye eye, bool earlier_layout) {
      const int64_t t = t0 + int64_t(pose_seq) * 1'000'000;
      const hullpipe_msg_ViewPose pose = dds::ViewToMsg(v, pose_seq, 1, t, 0, eye);
      std::vector<uint8_t> bytes = pose_codec->Encode(&pose);
      w.Append({tp, t, t, earlier_layout ? earlier(bytes) : bytes});
      HullTile tile;
      tile.rect = cv::Rect(0, 0, v.width, v.height);
      tile.depth = cv::Mat(tile.rect.size(), CV_32FC1, cv::Scalar(2.0f));
      tile.colour = cv::Mat(tile.rect.size(), CV_8UC3, cv::Scalar(10, 20, 30));
      tile.pose_seq = pose_seq, tile.frame_seq = 1, tile.capture_time_ns = t0;
      const auto hull = dds::MakeHullViewMessage(tile, 10);
      w.Append({th, t + 1000, t + 1000, tile_codec->Encode(&hull.msg)});
      const auto composite =
          dds::MakeCompositedViewMessage(tile.colour, pose_seq, 1, t0, 0, {1280, 90}, eye);
      bytes = view_codec->Encode(&composite.msg);
      w.Append({tc, t + 2000, t + 2000, earlier_layout ? earlier(bytes) : bytes});
    };
    add(1, eyes.eye[0], ViewEye::kLeft, false);
    add(2, eyes.eye[1], ViewEye::kRight, false);
    add(3, NovelView::FromFov(32, 24, 1.0, head), ViewEye::kMono, true);
  }
  const std::string out = (dir / "export").string(), log = (dir / "export.log").string();
  test::Process exp({test::BinDir() + "/hullpipe_record", "export", rec, "-o", out, "--ros2", "--foxglove",
                     "--domain", std::to_string(domain)},
                    log);
  ASSERT_EQ(exp.Wait(120), 0) << test::ReadFile(log);
  // JSON lines name each view's eye (VIEW_EYE_*: left 1, right 2, the one view 0).
  for (const char* topic : {"hullpipe_view_pose", "hullpipe_composited_view"}) {
    std::ifstream lines(out + "/" + topic + ".jsonl");
    std::vector<int> got;
    for (std::string line; std::getline(lines, line);) got.push_back(json::parse(line)["eye"].get<int>());
    EXPECT_EQ(got, (std::vector<int>{1, 2, 0})) << topic;
  }
  // A video per eye beside the one view's.
  for (const char* video : {"composited", "composited_left", "composited_right", "hull_view", "hull_view_left",
                            "hull_view_right"})
    EXPECT_TRUE(std::filesystem::exists(out + "/" + video + ".mp4")) << video;

  const std::string js = std::string(HULLPIPE_SOURCE_DIR) + "/tests/js";
  const auto read = [&](const char* script, const std::string& file) {
    const std::string node_out = (dir / (std::string(script) + ".json")).string();
    test::Process node({"/usr/bin/env", "node", js + "/" + script, file}, node_out, {}, node_out + ".err");
    EXPECT_EQ(node.Wait(120), 0) << test::ReadFile(node_out + ".err");
    return json::parse(test::ReadFile(node_out));
  };
  const json r = read("read_ros2_mcap.mjs", out + "/ros2.mcap");
  EXPECT_TRUE(r["invalid"].empty()) << r["invalid"].dump();
  const json& ch = r["channels"];
  const std::map<std::string, std::pair<int, json>> want = {
      {"/tf", {3, json::array({"hullpipe_view_left", "hullpipe_view_right", "hullpipe_view"})}},
      {"/hullpipe/view/left/compressed", {1, json::array({"hullpipe_view_left"})}},
      {"/hullpipe/view/right/compressed", {1, json::array({"hullpipe_view_right"})}},
      {"/hullpipe/view/compressed", {1, json::array({"hullpipe_view"})}},
      {"/hullpipe/hull_points", {2, json::array({"hullpipe_world"})}}};  // the left eye's and the one view's
  EXPECT_EQ(ch.size(), want.size()) << ch.dump(1);
  for (const auto& [topic, w] : want) {
    ASSERT_TRUE(ch.contains(topic)) << topic << " " << ch.dump(1);
    EXPECT_EQ(ch[topic]["decoded"], w.first) << topic;
    EXPECT_EQ(r["frames"][topic], w.second) << topic;
  }
  // The left eye's frame where the head's pose puts it: half the IPD along the head's -x.
  const json& left_tf = r["first"]["/tf"]["transforms"][0]["transform"]["translation"];
  const Eigen::Vector3d left_at = eyes.eye[0].world_from_eye.translation;
  EXPECT_NEAR(left_tf["x"].get<double>(), left_at.x(), 1e-12);
  EXPECT_NEAR(left_tf["y"].get<double>(), left_at.y(), 1e-12);
  EXPECT_NEAR((left_at - head.translation).norm(), so.ipd_m / 2, 1e-12);

  const json f = read("read_mcap.mjs", out + "/foxglove.mcap");
  EXPECT_TRUE(f["invalid"].empty()) << f["invalid"].dump();
  const json& fc = f["channels"];
  for (const auto& [topic, frame] : std::map<std::string, std::string>{{"/foxglove/composited/left", "view_left"},
                                                                       {"/foxglove/composited/right", "view_right"},
                                                                       {"/foxglove/composited", "view"},
                                                                       {"/foxglove/hull_view/left", "view_left"},
                                                                       {"/foxglove/hull_view/right", "view_right"},
                                                                       {"/foxglove/hull_view", "view"}}) {
    ASSERT_TRUE(fc.contains(topic)) << topic << " " << fc.dump(1);
    EXPECT_EQ(fc[topic]["decoded"], 1) << topic;
    EXPECT_EQ(fc[topic]["first"]["frame_id"], frame) << topic;
  }
  EXPECT_EQ(fc["/foxglove/hull_points"]["decoded"], 2) << "one cloud per frameset, and the one view's";
}

// The markers of a box, a contact and a mesh, field by field as Foxglove's ROS 2
// Humble reader decodes them (the ball's is above).
TEST_F(Ros2Messages, BoxesContactsAndMeshesAreMarkersFoxglovesDecoderReads) {
  VirtualObjectSample box;
  box.object_id = 2, box.shape = VirtualObjectSample::Shape::kBox, box.half_extents = {0.1, 0.2, 0.3};
  box.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()));
  const auto box_marker = ros2::MakeObjectMarker(box, 5);
  const auto contacts = ros2::MakeContactMarker(1, {{0.1, 0.2, 0.3}, {0.4, 0.5, 0.6}}, 5);
  VirtualMeshSample mesh;
  mesh.object_id = 100;
  mesh.draw.vertices = {{0, 0, -1}, {0.1, 0, -1}, {0, 0.1, -1}, {0.1, 0.1, -1}};
  mesh.draw.triangles = {{0, 1, 2}, {1, 3, 2}};
  mesh.draw.colliding = {0, 1};
  mesh.draw.colour = cv::Vec3b(255, 0, 0);  // BGR blue
  const auto mesh_marker = ros2::MakeMeshMarker(mesh, 5);
  const dds::KnownType kt = ros2::Ros2KnownType("visualization_msgs/msg/MarkerArray");
  const auto decoded = Decode({{"visualization_msgs/msg/MarkerArray", Encode(kt, &box_marker.msg)},
                               {"visualization_msgs/msg/MarkerArray", Encode(kt, &contacts.msg)},
                               {"visualization_msgs/msg/MarkerArray", Encode(kt, &mesh_marker.msg)}});
  ASSERT_EQ(decoded.size(), 3u);
  for (const json& d : decoded) ASSERT_FALSE(d.contains("error")) << d.dump();
  const json& b = decoded[0]["markers"][0];
  EXPECT_EQ(b["type"], 1);  // CUBE
  EXPECT_DOUBLE_EQ(b["scale"]["z"].get<double>(), 0.6);
  EXPECT_NEAR(b["pose"]["orientation"]["z"].get<double>(), std::sin(0.25), 1e-12);
  const json& c = decoded[1]["markers"][0];
  EXPECT_EQ(c["type"], 7);  // SPHERE_LIST
  ASSERT_EQ(c["points"].size(), 2u);
  EXPECT_DOUBLE_EQ(c["points"][1]["y"].get<double>(), 0.5);
  const json& m = decoded[2]["markers"][0];
  EXPECT_EQ(m["type"], 11);  // TRIANGLE_LIST: each triangle's vertices in turn
  ASSERT_EQ(m["points"].size(), 6u);
  EXPECT_DOUBLE_EQ(m["points"][3]["x"].get<double>(), 0.1);  // triangle 1's first vertex, vertex 1
  ASSERT_EQ(m["colors"].size(), 6u);
  EXPECT_NEAR(m["colors"][0]["b"].get<double>(), 1.0, 1e-6);  // triangle 0: its colour
  EXPECT_NEAR(m["colors"][3]["r"].get<double>(), 0.9, 1e-6);  // triangle 1 collides: red
}

// A collision report with §4.2's response as hullpipe_msgs/CollisionReport,
// decoded with the fields of the ament package's .msg file (parsed by
// Foxglove's parser), not hullpipe's IDL; and CAD model parts as markers in
// their own frames with their poses on /tf.
TEST_F(Ros2Messages, CollisionReportsAndModelPartsDecodeWithTheirDefinitions) {
  CollisionReportSample r;
  r.object_id = 7, r.frame_seq = 123456789012ull, r.capture_time_ns = 1'700'000'000'250'000'000;
  r.triangle_ids = {4, 9, 4000000000u};
  r.collision_points = {{0.1, -0.2, -1.25}, {0.125, -0.5, -1.0}};
  r.has_response = true;
  r.cp_obj = {0.5, 0.25, -1.5}, r.cp_hull = {0.5, 0.25, -1.375};
  r.v_rec = {0, 0, 1}, r.d_rec = 0.125, r.n_hull = {0, 0.6, 0.8};
  r.hull_velocity_status = 2, r.hull_normal_speed = -0.75, r.hull_velocity_interval = 0.02;
  const auto report = ros2::MakeCollisionReport(r);

  ModelPartSample a, b;
  a.object_id = 500, a.model_id = 500, a.part_index = 0, a.part_count = 2;
  a.vertices = {{0, 0, 0}, {0.5f, 0, 0}, {0, 0.25f, 0}, {0, 0, 0.125f}};
  a.triangles = {{0, 2, 1}, {0, 1, 3}};
  a.colour = cv::Vec3b(0, 255, 0);  // BGR green
  b = a;
  b.object_id = 501, b.part_index = 1;
  b.triangles = {{1, 2, 3}};
  const auto markers = ros2::MakeModelMarkers({{&a, kPartClear}, {&b, kPartColliding}}, 5);
  ModelStateSample state;
  state.model_id = 500, state.capture_time_ns = 5;
  state.parts.resize(2);
  state.parts[1].position = {1, 2, 3};
  state.parts[1].orientation = {std::cos(0.25), 0, 0, std::sin(0.25)};  // 0.5 rad about z
  const auto tf = ros2::MakePartTransforms(state);

  auto encode = [&](const char* type, const void* msg) { return Encode(ros2::Ros2KnownType(type), msg); };
  const auto decoded =
      Decode({{"hullpipe_msgs/msg/CollisionReport", encode("hullpipe_msgs/msg/CollisionReport", &report.msg)},
              {"visualization_msgs/msg/MarkerArray", encode("visualization_msgs/msg/MarkerArray", &markers.msg)},
              {"tf2_msgs/msg/TFMessage", encode("tf2_msgs/msg/TFMessage", &tf.msg)}});
  ASSERT_EQ(decoded.size(), 3u);
  for (const json& d : decoded) ASSERT_FALSE(d.contains("error")) << d.dump();
  const json& c = decoded[0];
  EXPECT_EQ(c["header"]["frame_id"], "hullpipe_world");
  EXPECT_EQ(c["header"]["stamp"]["sec"], 1'700'000'000);
  EXPECT_EQ(c["header"]["stamp"]["nanosec"], 250'000'000);
  EXPECT_EQ(c["object_id"], 7);
  EXPECT_EQ(c["frame_seq"].get<uint64_t>(), 123456789012ull);
  EXPECT_EQ(c["triangle_ids"], json::array({4, 9, 4000000000u}));
  ASSERT_EQ(c["collision_points"].size(), 2u);
  EXPECT_DOUBLE_EQ(c["collision_points"][1]["y"].get<double>(), -0.5);
  EXPECT_EQ(c["has_response"], true);
  EXPECT_DOUBLE_EQ(c["cp_obj"]["y"].get<double>(), 0.25);
  EXPECT_DOUBLE_EQ(c["cp_hull"]["z"].get<double>(), -1.375);
  EXPECT_DOUBLE_EQ(c["v_rec"]["z"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(c["d_rec"].get<double>(), 0.125);
  EXPECT_DOUBLE_EQ(c["n_hull"]["y"].get<double>(), 0.6);
  EXPECT_EQ(c["hull_velocity_status"], 2);
  EXPECT_DOUBLE_EQ(c["hull_normal_speed"].get<double>(), -0.75);
  EXPECT_DOUBLE_EQ(c["hull_velocity_interval"].get<double>(), 0.02);

  const json& parts = decoded[1]["markers"];
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[0]["ns"], "hullpipe_models");
  EXPECT_EQ(parts[0]["id"], 500);
  EXPECT_EQ(parts[0]["type"], 11);  // TRIANGLE_LIST
  EXPECT_EQ(parts[0]["header"]["frame_id"], "hullpipe_part500");
  EXPECT_EQ(parts[0]["frame_locked"], true);
  ASSERT_EQ(parts[0]["points"].size(), 6u);
  EXPECT_DOUBLE_EQ(parts[0]["points"][1]["y"].get<double>(), 0.25);  // triangle 0's second vertex: vertex 2
  EXPECT_DOUBLE_EQ(parts[0]["points"][5]["z"].get<double>(), 0.125);
  EXPECT_NEAR(parts[0]["color"]["g"].get<double>(), 1.0, 1e-6);  // its material, clear
  EXPECT_EQ(parts[1]["header"]["frame_id"], "hullpipe_part501");
  ASSERT_EQ(parts[1]["points"].size(), 3u);
  EXPECT_NEAR(parts[1]["color"]["r"].get<double>(), 0.9, 1e-6);  // colliding: red
  const json& transforms = decoded[2]["transforms"];
  ASSERT_EQ(transforms.size(), 2u);
  EXPECT_EQ(transforms[1]["header"]["frame_id"], "hullpipe_world");
  EXPECT_EQ(transforms[1]["child_frame_id"], "hullpipe_part501");
  EXPECT_DOUBLE_EQ(transforms[1]["transform"]["translation"]["z"].get<double>(), 3.0);
  EXPECT_NEAR(transforms[1]["transform"]["rotation"]["z"].get<double>(), std::sin(0.25), 1e-12);
  EXPECT_NEAR(transforms[1]["transform"]["rotation"]["w"].get<double>(), std::cos(0.25), 1e-12);
}

// The deriver draws a model's parts once their geometry came, sends the
// geometry again only when a part's contact state changes (and at most every
// model_marker_period_s of capture time, the latest state sent once it is
// due), and refuses parts past its bound, counted.
TEST(Ros2Deriver, ModelPartsAreSentAgainOnlyWhenAContactChangesAndAreBounded) {
  std::vector<std::pair<std::string, int64_t>> out;
  std::vector<std::vector<float>> colours;  // per model_markers message: each part's red
  ros2::Ros2Deriver deriver({}, [&](const ros2::Ros2Message& m) {
    out.push_back({m.topic, m.stamp_ns});
    if (m.topic != "/hullpipe/model_markers") return;
    const auto* a = static_cast<const visualization_msgs_msg_dds__MarkerArray_*>(m.msg);
    std::vector<float> reds;
    for (uint32_t i = 0; i < a->markers._length; ++i) reds.push_back(a->markers._buffer[i].color.r);
    colours.push_back(reds);
  });
  auto count = [&](const std::string& topic) {
    return std::count_if(out.begin(), out.end(), [&](const auto& o) { return o.first == topic; });
  };
  ModelPartSample part;
  part.model_id = 10, part.part_count = 2;
  part.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  part.triangles = {{0, 1, 2}};
  part.colour = cv::Vec3b(0, 0, 0);  // black: red 0 when clear
  ModelStateSample state;
  state.model_id = 10;
  state.parts.resize(2);
  auto step = [&](int64_t t_ms, uint8_t contact1) {
    state.capture_time_ns = t_ms * 1'000'000;
    state.parts[1].contact = contact1;
    const auto m = dds::MakeModelStateMessage(state);
    EXPECT_EQ(deriver.OnModelState(m.msg), "");
  };
  step(0, kPartClear);  // no geometry yet: nothing
  EXPECT_TRUE(out.empty());
  for (uint32_t i : {0u, 1u}) {
    part.object_id = 10 + i, part.part_index = i;
    EXPECT_EQ(deriver.OnModelPart(dds::MakeModelPartMessage(part).msg), "");
  }
  step(20, kPartClear);  // first: the geometry and the poses
  EXPECT_EQ(count("/hullpipe/model_markers"), 1);
  EXPECT_EQ(count("/tf"), 2 - 1);
  step(40, kPartClear);  // nothing changed: poses only
  EXPECT_EQ(count("/hullpipe/model_markers"), 1);
  EXPECT_EQ(count("/tf"), 2);
  step(60, kPartColliding);  // changed within 0.2 s of the last: held
  EXPECT_EQ(count("/hullpipe/model_markers"), 1);
  step(219, kPartColliding);
  EXPECT_EQ(count("/hullpipe/model_markers"), 1);
  step(220, kPartColliding);  // due: the colliding part red
  ASSERT_EQ(count("/hullpipe/model_markers"), 2);
  EXPECT_EQ(colours.back(), (std::vector<float>{0.f, 0.9f}));
  EXPECT_EQ(out.back().second, 220'000'000);
  step(500, kPartColliding);  // unchanged: none
  EXPECT_EQ(count("/hullpipe/model_markers"), 2);
  EXPECT_EQ(count("/tf"), 6);

  // Past the bound of triangles in all: refused, named, counted; the others stay.
  ModelPartSample big;
  big.object_id = 99, big.model_id = 99;
  big.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  big.triangles.assign(ros2::Ros2Deriver::kMaxModelTriangles, Eigen::Vector3i(0, 1, 2));
  const std::string why = deriver.OnModelPart(dds::MakeModelPartMessage(big).msg);
  EXPECT_NE(why.find("ModelPart 99: past the markers' bound"), std::string::npos) << why;
  EXPECT_EQ(deriver.counts().parts_refused, 1u);
  step(800, kPartClear);
  ASSERT_EQ(count("/hullpipe/model_markers"), 3);
  EXPECT_EQ(colours.back().size(), 2u);  // the two parts, not the refused one
}

// A camera image sent as a region (capture_node --image-region) goes out as
// the camera's whole image, black around the region, encoded again; a whole
// JPEG is passed on byte for byte; raw regions go out whole as bgr8.
TEST(Ros2Deriver, AnImageRegionGoesOutAsItsWholeImage) {
  std::vector<std::pair<std::string, std::vector<uint8_t>>> out;
  ros2::Ros2Deriver deriver({}, [&](const ros2::Ros2Message& m) {
    if (m.type == "sensor_msgs/msg/CompressedImage") {
      const auto* c = static_cast<const sensor_msgs_msg_dds__CompressedImage_*>(m.msg);
      out.push_back({m.topic, std::vector<uint8_t>(c->data._buffer, c->data._buffer + c->data._length)});
    } else if (m.type == "sensor_msgs/msg/Image") {
      const auto* i = static_cast<const sensor_msgs_msg_dds__Image_*>(m.msg);
      EXPECT_EQ(i->width, 64u);
      EXPECT_EQ(i->height, 48u);
      out.push_back({m.topic, std::vector<uint8_t>(i->data._buffer, i->data._buffer + i->data._length)});
    }
  });
  Camera cam = RingCameras(1, 3, 2, Eigen::Vector3d::Zero(), 64, 48, 1.0, Distortion{})[0];
  cam.id = 1;
  EXPECT_EQ(deriver.OnCameraInfo(dds::CameraToMsg(cam, {}), 1), "");
  out.clear();
  const cv::Mat bgr(48, 64, CV_8UC3, cv::Scalar(40, 160, 220));
  const cv::Rect part(16, 8, 24, 20);
  const auto whole = dds::MakeImageMessage(1, 1, 1000, bgr, 80);
  EXPECT_EQ(deriver.OnImage(whole.msg), "");
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].first, "/hullpipe/cam1/image/compressed");
  EXPECT_EQ(out[0].second, whole.bytes) << "a whole JPEG passed on as it is";
  for (const int quality : {80, 0}) {
    out.clear();
    const auto region = dds::MakeImageMessage(1, 2, 2000, bgr, quality, part);
    EXPECT_EQ(deriver.OnImage(region.msg), "");
    ASSERT_EQ(out.size(), 1u);
    const cv::Mat shown = quality ? cv::imdecode(out[0].second, cv::IMREAD_COLOR)
                                  : cv::Mat(48, 64, CV_8UC3, out[0].second.data()).clone();
    ASSERT_EQ(shown.size(), cv::Size(64, 48)) << quality;
    // Inside the region (a pixel in from its edge, where JPEG's blocks blur
    // the step): the camera's colour; well outside it: black.
    const double tol = quality ? 12 : 0;  // JPEG 80 twice over, on a flat colour
    EXPECT_LE(cv::norm(shown(cv::Rect(18, 10, 20, 16)), bgr(cv::Rect(18, 10, 20, 16)), cv::NORM_INF), tol);
    EXPECT_LE(cv::norm(shown(cv::Rect(0, 0, 8, 48)), cv::NORM_INF), tol);
    EXPECT_LE(cv::norm(shown(cv::Rect(48, 0, 16, 48)), cv::NORM_INF), tol);
  }
  // A region whose whole image is larger than the camera's calibration:
  // refused, named, before its whole image is made.
  out.clear();
  auto huge = dds::MakeImageMessage(1, 3, 3000, bgr, 80, part);
  huge.msg.full_width = huge.msg.full_height = 16384;
  const std::string why = deriver.OnImage(huge.msg);
  EXPECT_NE(why.find("whole image 16384x16384 is larger than its calibration's 64x48"), std::string::npos) << why;
  EXPECT_TRUE(out.empty());
}

}  // namespace
}  // namespace hullpipe
