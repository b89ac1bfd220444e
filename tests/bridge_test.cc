// hullpipe_bridge (docs/recording.md, "Live view"): the Foxglove WebSocket
// protocol's state alone (BridgeState), then the bridge as a process on a live
// synthetic pipeline, judged by a client nobody here wrote (@foxglove/ws-protocol,
// tests/js/ws_client.mjs), a client that never reads, a refused subprotocol, and
// a stop within a second of SIGINT.
#include <csignal>
#include <filesystem>
#include <regex>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "hullpipe/foxglove/bridge_channels.h"
#include "hullpipe/foxglove/bridge_state.h"
#include "hullpipe/foxglove/channels.h"
#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/geometry/conventions.h"
#include "test_util.h"

namespace hullpipe {
namespace {

using bridge::BridgeState;
using bridge::Channel;
using nlohmann::json;

// The bytes of a base64 text (RFC 4648, with padding), as a viewer reads a
// foxglove.CompressedImage's data.
std::vector<uint8_t> Base64Decode(const std::string& text) {
  static const std::string kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::vector<uint8_t> out;
  uint32_t bits = 0;
  int n = 0;
  for (const char c : text) {
    if (c == '=') break;
    const size_t v = kAlphabet.find(c);
    if (v == std::string::npos) continue;
    bits = (bits << 6) | uint32_t(v);
    if ((n += 6) >= 8) out.push_back(uint8_t(bits >> (n -= 8)));
  }
  return out;
}

std::vector<Channel> TwoChannels() {
  return {{1, "hullpipe/camera_info", "cdr", "hullpipe::msg::CameraInfo", "module hullpipe {};", "omgidl"},
          {2, "hullpipe/object_pixel_map", "cdr", "hullpipe::msg::ObjectPixelMap", "module hullpipe {};", "omgidl"}};
}

// The protocol (ws-protocol spec v1): the subprotocol chosen, serverInfo then
// advertise on open (no clientPublish capability), subscriptions routed as
// binary message data (opcode 1, subscription id, timestamp, payload, little
// endian), unsubscribe, errors as status messages, the client bound.
TEST(BridgeState, SpeaksTheFoxgloveWebSocketProtocol) {
  BridgeState s(TwoChannels(), 2, "hullpipe_bridge");
  std::string why;
  EXPECT_EQ(s.Accept({"foxglove.websocket.v1"}, 0, &why), "foxglove.websocket.v1");
  EXPECT_EQ(s.Accept({"foxglove.websocket.v1", "foxglove.sdk.v1"}, 0, &why), "foxglove.sdk.v1");
  EXPECT_EQ(s.Accept({"chat"}, 0, &why), "");
  EXPECT_NE(why.find("subprotocol"), std::string::npos);
  const auto open = s.Open(7, "abc");
  ASSERT_EQ(open.size(), 2u);
  const json info = json::parse(open[0].payload), adv = json::parse(open[1].payload);
  EXPECT_EQ(info["op"], "serverInfo");
  EXPECT_EQ(info["capabilities"], json::array());
  EXPECT_EQ(info["sessionId"], "abc");
  EXPECT_EQ(adv["op"], "advertise");
  ASSERT_EQ(adv["channels"].size(), 2u);
  EXPECT_EQ(adv["channels"][1]["topic"], "hullpipe/object_pixel_map");
  EXPECT_EQ(adv["channels"][1]["schemaEncoding"], "omgidl");
  EXPECT_TRUE(s.Wanted().empty());
  EXPECT_TRUE(s.Route(2, 5, {1, 2, 3}).empty());  // nobody subscribed: nothing
  EXPECT_TRUE(s.OnText(7, R"({"op":"subscribe","subscriptions":[{"id":40,"channelId":2}]})").empty());
  EXPECT_EQ(s.Wanted(), std::set<uint32_t>{2});
  const auto routed = s.Route(2, 0x0102030405060708ull, {0xAA, 0xBB});
  ASSERT_EQ(routed.size(), 1u);
  EXPECT_TRUE(routed[0].binary);
  EXPECT_EQ(routed[0].client, 7u);
  const std::string want("\x01\x28\x00\x00\x00\x08\x07\x06\x05\x04\x03\x02\x01\xAA\xBB", 15);
  EXPECT_EQ(routed[0].payload, want);
  EXPECT_TRUE(s.Route(1, 0, {1}).empty());  // another channel
  // Errors: each a status message naming what is wrong, nothing else changed.
  for (const std::string bad :
       {R"(not json)", R"({"op":"subscribe","subscriptions":[{"id":41,"channelId":99}]})",
        R"({"op":"subscribe","subscriptions":[{"id":40,"channelId":1}]})", R"({"op":"advertise","channels":[]})",
        R"({"op":"subscribe"})", R"({"op":"getParameters","parameterNames":[]})"}) {
    const auto out = s.OnText(7, bad);
    ASSERT_EQ(out.size(), 1u) << bad;
    const json st = json::parse(out[0].payload);
    EXPECT_EQ(st["op"], "status") << bad;
    EXPECT_FALSE(st["message"].get<std::string>().empty());
  }
  EXPECT_EQ(s.Wanted(), std::set<uint32_t>{2});
  EXPECT_TRUE(s.OnText(7, R"({"op":"unsubscribe","subscriptionIds":[40]})").empty());
  EXPECT_TRUE(s.Wanted().empty());
  EXPECT_TRUE(s.Route(2, 5, {1}).empty());  // (the positive control is the route above)
  // The client bound.
  s.Open(8, "d");
  EXPECT_EQ(s.Accept({"foxglove.websocket.v1"}, 0, &why), "");
  EXPECT_NE(why.find("--max-clients"), std::string::npos);
  s.Close(8);
  EXPECT_EQ(s.Accept({"foxglove.websocket.v1"}, 0, &why), "foxglove.websocket.v1");
}

// What hostile clients sent, each answered by one status error and nothing
// else changed: a second subscription to a channel already subscribed (100,000
// of them once copied each image 100,000 times), a channel id past 2^32 - 1
// (2^32 + 3 was channel 3), JSON nested past the bound or text past the size
// bound (refused before parsing; a 30-MB nested text cost 843 MB), an unknown
// operation whose name is 1 MB (echoed whole before). Handshakes accepted but
// not yet open count against the client bound (500 at once got 128 clients in
// past --max-clients 8).
TEST(BridgeState, HostileMessagesAreBoundedAndAnsweredOnce) {
  BridgeState s(TwoChannels(), 2, "hullpipe_bridge");
  s.Open(7, "abc");
  EXPECT_TRUE(s.OnText(7, R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":2}]})").empty());
  const auto status = [&](const std::string& text) {
    const auto out = s.OnText(7, text);
    EXPECT_EQ(out.size(), 1u) << text.substr(0, 100);
    return out.empty() ? std::string() : json::parse(out[0].payload)["message"].get<std::string>();
  };
  EXPECT_NE(status(R"({"op":"subscribe","subscriptions":[{"id":2,"channelId":2}]})").find("already subscribed as 1"),
            std::string::npos);
  std::string many = R"({"op":"subscribe","subscriptions":[)";
  for (int k = 3; k < 1003; ++k)
    many += (k > 3 ? "," : "") + std::string(R"({"id":)") + std::to_string(k) + R"(,"channelId":2})";
  EXPECT_EQ(s.OnText(7, many + "]}").size(), 1000u);  // 1000 refusals, no subscription
  EXPECT_EQ(s.Route(2, 0, {1}).size(), 1u) << "one copy of each sample for the one subscription";
  EXPECT_EQ(status(R"({"op":"subscribe","subscriptions":[{"id":5,"channelId":4294967297}]})"), "no channel 4294967297");
  EXPECT_EQ(s.Wanted(), std::set<uint32_t>{2}) << "channel 1 (2^32 + 1 cut to 32 bits) is not subscribed";
  std::string deep(BridgeState::kMaxJsonDepth + 1, '[');
  EXPECT_NE(status(deep + std::string(BridgeState::kMaxJsonDepth + 1, ']')).find("nested deeper"), std::string::npos);
  EXPECT_NE(status(R"({"op":"x","s":")" + std::string(BridgeState::kMaxTextBytes, 'a') + "\"}").find("at most"),
            std::string::npos);
  // The control: brackets inside a string are no nesting.
  EXPECT_EQ(status(R"({"op":"subscribe","subscriptions":[{"id":9,"channelId":77}],"note":"[[[[[[[[[[[[[["})"),
            "no channel 77");
  const std::string long_op = status(R"({"op":")" + std::string(1 << 19, 'o') + R"("})");
  EXPECT_LT(long_op.size(), 200u);
  EXPECT_NE(long_op.find("is not supported"), std::string::npos) << long_op.substr(0, 200);
  // The client bound with handshakes in flight: one open, one handshaking.
  std::string why;
  EXPECT_EQ(s.Accept({"foxglove.websocket.v1"}, 1, &why), "");
  EXPECT_EQ(s.Accept({"foxglove.websocket.v1"}, 0, &why), "foxglove.websocket.v1");
}

// Channels that appear after clients connected (a camera's, when its
// calibration arrives) are advertised to every connected client and are in the
// first advertise of a client that connects later; latched state (the latest
// per key) reaches each new subscription at once; the latch is bounded.
TEST(BridgeState, LateChannelsAreAdvertisedAndLatchedStateReachesLateSubscribers) {
  BridgeState s(TwoChannels(), 4, "hullpipe_bridge");
  s.Open(1, "a");
  const Channel cal{10, "/foxglove/cam3/calibration", "json", "foxglove.CameraCalibration", "{}", "jsonschema"};
  const auto adv = s.Advertise({cal});
  ASSERT_EQ(adv.size(), 1u);
  EXPECT_EQ(adv[0].client, 1u);
  const json a = json::parse(adv[0].payload);
  EXPECT_EQ(a["op"], "advertise");
  ASSERT_EQ(a["channels"].size(), 1u);
  EXPECT_EQ(a["channels"][0]["topic"], "/foxglove/cam3/calibration");
  EXPECT_EQ(a["channels"][0]["encoding"], "json");
  EXPECT_EQ(a["channels"][0]["schemaEncoding"], "jsonschema");
  EXPECT_TRUE(s.Advertise({cal}).empty()) << "an id already advertised is not again";
  const auto open = s.Open(2, "b");
  EXPECT_EQ(json::parse(open[1].payload)["channels"].size(), 3u);
  EXPECT_EQ(s.channels().size(), 3u);
  // Nothing latched yet: a subscription gets nothing at once (the control for below).
  EXPECT_TRUE(s.OnText(1, R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":10}]})").empty());
  EXPECT_TRUE(s.Latch(10, "cam3", 5, {'x'}));
  EXPECT_TRUE(s.Latch(10, "cam3", 6, {'y'}));  // replaces
  EXPECT_TRUE(s.Latch(10, "cam4", 7, {'z'}));
  const auto out = s.OnText(2, R"({"op":"subscribe","subscriptions":[{"id":9,"channelId":10}]})");
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].client, 2u);
  EXPECT_TRUE(out[0].binary);
  EXPECT_EQ(out[0].payload, std::string("\x01\x09\x00\x00\x00\x06\x00\x00\x00\x00\x00\x00\x00y", 14));
  EXPECT_EQ(out[1].payload.back(), 'z');
  // Another channel's subscription gets none of them.
  EXPECT_TRUE(s.OnText(2, R"({"op":"subscribe","subscriptions":[{"id":3,"channelId":1}]})").empty());
  for (int i = 0; i < 4096; ++i) ASSERT_TRUE(s.Latch(2, std::to_string(i), 0, {1}));
  EXPECT_FALSE(s.Latch(2, "one more", 0, {1}));
  EXPECT_TRUE(s.Latch(2, "17", 0, {2})) << "a kept key is still replaced";
}

// The viewable channels derived from hullpipe samples as they are on the wire:
// the calibration with Foxglove's pixel centres and the camera's pose, both
// latched per camera; an image encoded to JPEG and a JPEG passed through byte
// for byte; a channel nobody wants costs nothing; a CAD model's part sent when
// it first has a pose and again only when its contact changes; bytes that do
// not decode refused; the per-camera topics parsed back.
// The bridge's channel table: hullpipe's types first (type i on channel i + 1),
// a camera's viewable channels added once when its first message comes, at
// most kMaxCameras cameras; and the readers the wanted channels need.
TEST(BridgeChannels, CamerasJoinOnceUpToTheBoundAndWantedChannelsNameTheirReaders) {
  const auto& types = dds::KnownTypes();
  foxglove::BridgeChannels table(types);
  const size_t initial = table.channels().size();
  ASSERT_GT(initial, types.size());  // the fixed viewable channels follow the types
  for (size_t i = 0; i < types.size(); ++i) {
    EXPECT_EQ(table.channels()[i].id, uint32_t(i + 1));
    EXPECT_EQ(table.channels()[i].topic, types[i].topic_name);
  }
  std::vector<Channel> added;
  const auto cam3 = table.ChannelOf("/foxglove/cam3/image", &added);
  ASSERT_TRUE(cam3);
  ASSERT_EQ(added.size(), 3u);  // image, object_pixel_map, calibration
  EXPECT_EQ(table.channels().size(), initial + 3);
  added.clear();
  EXPECT_EQ(table.ChannelOf("/foxglove/cam3/calibration", &added).has_value(), true);
  EXPECT_TRUE(added.empty()) << "a camera's channels are advertised once";
  EXPECT_FALSE(table.ChannelOf("/foxglove/no_such_topic", &added));
  // The bound: kMaxCameras cameras in all; the next is refused and counted.
  for (uint32_t cam = 100; cam < 100 + foxglove::BridgeChannels::kMaxCameras - 1; ++cam)
    ASSERT_TRUE(table.ChannelOf("/foxglove/cam" + std::to_string(cam) + "/image", &added)) << cam;
  EXPECT_EQ(table.refused(), 0u);
  EXPECT_FALSE(table.ChannelOf("/foxglove/cam999/image", &added));
  EXPECT_FALSE(table.ChannelOf("/foxglove/cam999/image", &added));
  EXPECT_EQ(table.refused(), 2u);
  EXPECT_EQ(table.first_refused_camera(), 999);
  // Readers: a raw channel needs its own type; camera 3's image channel needs
  // the types it is derived from, never CameraInfo (always read).
  auto index = [&](const std::string& type_name) {
    for (size_t i = 0; i < types.size(); ++i)
      if (types[i].type_name == type_name) return i;
    return size_t(-1);
  };
  const size_t map_type = index("hullpipe::msg::ObjectPixelMap");
  foxglove::BridgeChannels::Needs needs = table.ReadersFor({uint32_t(map_type + 1)});
  EXPECT_EQ(needs.raw, std::set<size_t>{map_type});
  EXPECT_TRUE(needs.derived.empty());
  needs = table.ReadersFor({*cam3});
  EXPECT_TRUE(needs.raw.empty());
  EXPECT_EQ(needs.derived.count(index("hullpipe::msg::CameraImage")), 1u);
  EXPECT_EQ(needs.derived.count(table.camera_info()), 0u);
  EXPECT_EQ(needs.all, needs.derived);
  EXPECT_TRUE(table.IsWanted("/foxglove/cam3/image", {*cam3}));
  EXPECT_FALSE(table.IsWanted("/foxglove/cam3/image", {}));
  EXPECT_TRUE(table.ReadersFor({}).all.empty());  // no client: no reader but the calibration's
}

TEST(Foxglove, DerivesTheViewableChannelsFromSamplesOnTheWire) {
  const auto dir = test::TempDir("foxglove_derive");
  setenv("CYCLONEDDS_URI", ("file://" + test::WriteLoopbackConfig(dir)).c_str(), 1);
  dds::Participant p(test::UniqueDomain());
  std::vector<foxglove::Message> got;
  std::set<std::string> wanted = {"/foxglove/cam0/image", "/foxglove/scene"};
  foxglove::Deriver d(p, [&](foxglove::Message m) { got.push_back(std::move(m)); },
                      [&](const std::string& topic) { return wanted.count(topic) > 0; });
  const auto encode = [&](const std::string& type, const void* msg) {
    const dds::KnownType& kt = *dds::FindKnownType(type);
    return dds::CdrWriter(p, kt, kt.qos, dds::CdrWriter::Scope::kDecodeOnly).Encode(msg);
  };
  Camera cam = RingCameras(1, 3, 2, Eigen::Vector3d::Zero(), 64, 48, 1.0, Distortion{})[0];
  cam.id = 0;
  const hullpipe_msg_CameraInfo info = dds::CameraToMsg(cam, {});
  ASSERT_TRUE(d.Add("hullpipe::msg::CameraInfo", encode("hullpipe::msg::CameraInfo", &info), 42));
  ASSERT_EQ(got.size(), 2u) << "calibration and transform, wanted or not (latched)";
  EXPECT_EQ(got[0].topic, "/foxglove/cam0/calibration");
  EXPECT_EQ(got[0].latch_key, "cam0");
  const json calib = json::parse(got[0].json);
  EXPECT_EQ(calib["width"], 64);
  EXPECT_DOUBLE_EQ(calib["K"][2].get<double>(), cam.cx - kOpenCvToHullpipePixelOffset);
  EXPECT_EQ(got[1].topic, "/foxglove/tf");
  const json tf = json::parse(got[1].json)["transforms"][0];
  const Eigen::Vector3d centre = cam.Center();
  EXPECT_NEAR(tf["translation"]["x"].get<double>(), centre.x(), 1e-12);
  EXPECT_NEAR(tf["translation"]["z"].get<double>(), centre.z(), 1e-12);
  got.clear();

  cv::Mat bgr(48, 64, CV_8UC3, cv::Scalar(10, 200, 30));
  const auto raw = dds::MakeImageMessage(0, 1, 1000, bgr, 0);
  ASSERT_TRUE(d.Add("hullpipe::msg::CameraImage", encode("hullpipe::msg::CameraImage", &raw.msg), 1));
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].stamp_ns, 1000);
  EXPECT_EQ(json::parse(got[0].json)["format"], "jpeg");
  const auto jpeg = dds::MakeImageMessage(0, 2, 2000, bgr, 80);
  ASSERT_TRUE(d.Add("hullpipe::msg::CameraImage", encode("hullpipe::msg::CameraImage", &jpeg.msg), 2));
  ASSERT_EQ(got.size(), 2u);
  const std::string b64 = json::parse(got[1].json)["data"];
  EXPECT_EQ(b64.size(), (jpeg.msg.data._length + 2) / 3 * 4) << "passed through, not re-encoded";
  // Sent as a region (capture_node --image-region): shown in its whole image.
  const auto region = dds::MakeImageMessage(0, 3, 3000, bgr, 80, cv::Rect(16, 8, 24, 20));
  ASSERT_TRUE(d.Add("hullpipe::msg::CameraImage", encode("hullpipe::msg::CameraImage", &region.msg), 2));
  ASSERT_EQ(got.size(), 3u);
  {
    const json shown = json::parse(got[2].json);
    EXPECT_EQ(shown["format"], "jpeg");
    const cv::Mat img = cv::imdecode(Base64Decode(shown["data"].get<std::string>()), cv::IMREAD_COLOR);
    ASSERT_EQ(img.size(), cv::Size(64, 48)) << "the whole image, not the region";
    EXPECT_LE(cv::norm(img(cv::Rect(0, 0, 8, 48)), cv::NORM_INF), 12) << "black around the region";
    EXPECT_LE(cv::norm(img(cv::Rect(18, 10, 20, 16)), bgr(cv::Rect(18, 10, 20, 16)), cv::NORM_INF), 12);
  }
  got.erase(got.begin() + 2);
  // A region whose whole image is larger than the camera's calibration:
  // refused, nothing allocated or sent.
  auto huge = dds::MakeImageMessage(0, 4, 4000, bgr, 80, cv::Rect(16, 8, 24, 20));
  huge.msg.full_width = huge.msg.full_height = 16384;
  EXPECT_FALSE(d.Add("hullpipe::msg::CameraImage", encode("hullpipe::msg::CameraImage", &huge.msg), 3));
  EXPECT_EQ(got.size(), 2u);
  // Camera 1's image: nobody wants it, nothing derived (the sample is still valid).
  const auto other = dds::MakeImageMessage(1, 2, 2000, bgr, 0);
  EXPECT_TRUE(d.Add("hullpipe::msg::CameraImage", encode("hullpipe::msg::CameraImage", &other.msg), 3));
  EXPECT_EQ(got.size(), 2u);
  got.clear();

  ModelPartSample part;
  part.object_id = part.model_id = 100;
  part.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  part.triangles = {{0, 1, 2}};
  const auto part_msg = dds::MakeModelPartMessage(part);
  ASSERT_TRUE(d.Add("hullpipe::msg::ModelPart", encode("hullpipe::msg::ModelPart", &part_msg.msg), 4));
  ModelStateSample state;
  state.model_id = 100;
  state.parts.resize(1);
  state.parts[0].position = Eigen::Vector3d(0.5, 0, 0);
  for (int step = 0; step < 3; ++step) {
    state.frame_seq = uint64_t(step);
    const auto m = dds::MakeModelStateMessage(state);
    ASSERT_TRUE(d.Add("hullpipe::msg::ModelState", encode("hullpipe::msg::ModelState", &m.msg), 5));
  }
  ASSERT_EQ(got.size(), 1u) << "a part at rest is sent once";
  EXPECT_EQ(got[0].latch_key, "part100");
  const json e = json::parse(got[0].json)["entities"][0];
  EXPECT_EQ(e["triangles"][0]["indices"], json({0, 1, 2}));
  EXPECT_DOUBLE_EQ(e["triangles"][0]["pose"]["position"]["x"].get<double>(), 0.5);
  state.parts[0].contact = kPartColliding;
  const auto touched = dds::MakeModelStateMessage(state);
  ASSERT_TRUE(d.Add("hullpipe::msg::ModelState", encode("hullpipe::msg::ModelState", &touched.msg), 6));
  ASSERT_EQ(got.size(), 2u) << "its contact changed";
  EXPECT_DOUBLE_EQ(json::parse(got[1].json)["entities"][0]["triangles"][0]["color"]["r"].get<double>(), 1.0);
  got.clear();

  // A box state is a cube at its pose (SceneUpdate's cubes), red while it
  // collides; a ball's state a sphere.
  VirtualObjectSample box;
  box.object_id = 9;
  box.shape = VirtualObjectSample::Shape::kBox;
  box.half_extents = Eigen::Vector3d(0.1, 0.2, 0.3);
  box.position = Eigen::Vector3d(1, 2, 3);
  box.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()));
  box.colliding = true;
  const hullpipe_msg_VirtualObjectState box_msg = dds::VirtualObjectToMsg(box);
  ASSERT_TRUE(d.Add("hullpipe::msg::VirtualObjectState", encode("hullpipe::msg::VirtualObjectState", &box_msg), 8));
  ASSERT_EQ(got.size(), 1u);
  const json cube = json::parse(got[0].json)["entities"][0]["cubes"][0];
  EXPECT_DOUBLE_EQ(cube["size"]["z"].get<double>(), 0.6);
  EXPECT_DOUBLE_EQ(cube["pose"]["position"]["y"].get<double>(), 2.0);
  EXPECT_NEAR(cube["pose"]["orientation"]["z"].get<double>(), std::sin(0.25), 1e-12);
  EXPECT_DOUBLE_EQ(cube["color"]["r"].get<double>(), 1.0);
  EXPECT_TRUE(json::parse(got[0].json)["entities"][0]["spheres"].empty());

  EXPECT_FALSE(d.Add("hullpipe::msg::CameraInfo", {0, 1, 0, 0, 1, 2}, 7));
  EXPECT_FALSE(d.Add("no::such::Type", {0, 1, 0, 0}, 7));
  EXPECT_EQ(foxglove::CameraOfTopic("/foxglove/cam17/object_pixel_map"), 17);
  for (const std::string bad : {"/foxglove/cam/image", "/foxglove/cam01/image", "/foxglove/cam1/other",
                                "/foxglove/cam99999999999/image", "/foxglove/tf"})
    EXPECT_EQ(foxglove::CameraOfTopic(bad), -1) << bad;
  EXPECT_EQ(foxglove::SourceTypes("/foxglove/cam2/image"), std::vector<std::string>{"hullpipe::msg::CameraImage"});
  EXPECT_TRUE(foxglove::SourceTypes("hullpipe/camera_image").empty());
}

class BridgeProcess : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::TempDir("bridge");
    config_ = test::WriteLoopbackConfig(dir_);
    domain_ = test::UniqueDomain();
    js_ = std::string(HULLPIPE_SOURCE_DIR) + "/tests/js";
    ASSERT_TRUE(std::filesystem::exists(js_ + "/node_modules/@foxglove/ws-protocol"))
        << "the npm clients are missing: scripts/setup.sh installs them (npm ci in tests/js)";
  }
  std::unique_ptr<launch::Process> Start(const std::string& exe, const std::vector<std::string>& args) {
    const std::string log = (dir_ / (exe + ".log")).string();
    logs_[exe] = log;
    return test::StartExe(exe, args, domain_, config_, log);
  }
  std::string Log(const std::string& exe) { return test::ReadFile(logs_[exe]); }
  // The port the bridge logged (it listens on --port 0: any free one).
  int Port() {
    const std::regex re("ws://127\\.0\\.0\\.1:([0-9]+)");
    std::smatch m;
    const double end = MonotonicSeconds() + 20;
    while (MonotonicSeconds() < end) {
      const std::string log = Log("hullpipe_bridge");
      if (std::regex_search(log, m, re)) return std::stoi(m[1]);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return 0;
  }
  std::filesystem::path dir_;
  std::string config_, js_;
  uint32_t domain_ = 0;
  std::map<std::string, std::string> logs_;
};

// A live synthetic pipeline watched through the bridge by Foxglove's own client:
// every hullpipe topic advertised with its schema; the calibration (late, from
// the transient-local history), maps and images streamed and decoded; nothing
// after unsubscribing; a client that speaks another subprotocol refused; the
// bridge stops within a second of SIGINT.
TEST_F(BridgeProcess, FoxglovesClientWatchesALivePipeline) {
  auto bridge = Start("hullpipe_bridge", {"--port", "0"});
  const int port = Port();
  ASSERT_GT(port, 0) << Log("hullpipe_bridge");
  // The capture runs long enough for the client (at the camera rate, 8 s).
  auto capture = Start("capture_node", {"--synthetic", "--frames", "200"});
  const std::string url = "ws://127.0.0.1:" + std::to_string(port);
  const std::string out = (dir_ / "client.json").string();
  launch::Process client({"/usr/bin/env", "node", js_ + "/ws_client.mjs", url, "60", "hullpipe/camera_info=1",
                          "hullpipe/object_pixel_map=8", "hullpipe/camera_image=4"},
                         out, {}, out + ".err");
  ASSERT_EQ(client.Wait(90), 0) << test::ReadFile(out + ".err") << Log("hullpipe_bridge");
  const json j = json::parse(test::ReadFile(out));  // stdout alone
  EXPECT_EQ(j["serverInfo"]["name"], "hullpipe_bridge");
  EXPECT_GE(j["channels"].size(), 12u);
  EXPECT_GE(j["got"]["hullpipe/object_pixel_map"].get<int>(), 8);
  EXPECT_EQ(j["afterUnsubscribe"], 0) << "messages kept coming after unsubscribing";
  const auto& info = j["first"]["hullpipe/camera_info"];
  EXPECT_GT(info["width"].get<int>(), 0);
  EXPECT_EQ(info["K"].size(), 9u);
  EXPECT_GT(info["K"][0].get<double>(), 0.0);  // fx
  EXPECT_EQ(j["first"]["hullpipe/object_pixel_map"]["width"], info["width"]);
  // A client of another subprotocol is refused (HTTP 503), and the bridge says why.
  const std::string refused = (dir_ / "refused.log").string();
  launch::Process other({"/usr/bin/env", "node", "-e",
                         "const W=require('" + js_ + "/node_modules/ws');const w=new W('" + url +
                             "',['chat']);w.on('open',()=>process.exit(2));w.on('error',e=>{console.log(e.message);"
                             "process.exit(0)});"},
                        refused);
  EXPECT_EQ(other.Wait(30), 0) << test::ReadFile(refused);
  EXPECT_NE(test::ReadFile(refused).find("503"), std::string::npos) << test::ReadFile(refused);
  EXPECT_NE(Log("hullpipe_bridge").find("refused a client"), std::string::npos);
  const double t0 = MonotonicSeconds();
  bridge->Signal(SIGINT);
  EXPECT_EQ(bridge->Wait(5), 0) << Log("hullpipe_bridge");
  EXPECT_LT(MonotonicSeconds() - t0, 1.0 * test::TimeScale());
  capture->Stop();
}

// The viewable channels live: a whole synthetic pipeline watched through the
// bridge by Foxglove's client, every message checked against Foxglove's own
// JSON Schemas: a camera's calibration (subscribed to long after it was
// published: latched), images and object-pixel maps of the calibration's size,
// the transforms, the tiles' hull view and render_node's composite of the
// view's size, the hull points, the scene with the balls, node rates.
TEST_F(BridgeProcess, FoxglovesClientSeesTheViewableChannelsOfALivePipeline) {
  auto bridge = Start("hullpipe_bridge", {"--port", "0"});
  const int port = Port();
  ASSERT_GT(port, 0) << Log("hullpipe_bridge");
  const auto out_dir = dir_ / "run";
  launch::Process pipeline({test::BinDir() + "/hullpipe_launch", "--synthetic", "--frames", "150", "--fps", "10",
                            "--width", "320", "--height", "240", "--out", out_dir.string(), "--domain",
                            std::to_string(domain_), "--dds-config", config_},
                           (dir_ / "launch.log").string());
  const std::string url = "ws://127.0.0.1:" + std::to_string(port);
  const std::string out = (dir_ / "viewable.json").string();
  launch::Process client({"/usr/bin/env", "node", js_ + "/ws_client.mjs", url, "90", "/foxglove/cam1/calibration=1",
                          "/foxglove/cam1/image=2", "/foxglove/cam1/object_pixel_map=2", "/foxglove/tf=1",
                          "/foxglove/hull_view=2", "/foxglove/composited=2", "hullpipe/composited_view=1",
                          "/foxglove/hull_points=1", "/foxglove/scene=2",
                          "/foxglove/node_stats=2"},
                         out, {}, out + ".err");
  ASSERT_EQ(client.Wait(120), 0) << test::ReadFile(out + ".err") << Log("hullpipe_bridge")
                                 << test::ReadFile((dir_ / "launch.log").string());
  const json j = json::parse(test::ReadFile(out));
  EXPECT_EQ(j["invalid"], json::array()) << "messages Foxglove's schemas refuse";
  EXPECT_EQ(j["afterUnsubscribe"], 0);
  const auto& first = j["first"];
  const auto& cal = first["/foxglove/cam1/calibration"];
  EXPECT_EQ(cal["frame_id"], "cam1");
  EXPECT_EQ(cal["K"].size(), 9u);
  EXPECT_GT(cal["K"][0].get<double>(), 0.0);
  const auto& image = first["/foxglove/cam1/image"]["data"];
  EXPECT_EQ(image["format"], "jpeg");
  // capture_node publishes its colour images at --image-scale 0.5 by default.
  EXPECT_EQ(image["width"].get<int>(), cal["width"].get<int>() / 2);
  EXPECT_EQ(image["height"].get<int>(), cal["height"].get<int>() / 2);
  const auto& map = first["/foxglove/cam1/object_pixel_map"]["data"];
  EXPECT_EQ(map["format"], "png");
  EXPECT_EQ(map["width"], cal["width"]);
  const auto& view = first["/foxglove/hull_view"]["data"];
  EXPECT_EQ(view["width"], 320);
  EXPECT_EQ(view["height"], 240);
  // render_node's own composite (hull and balls), its JPEG passed through; the
  // raw topic decoded by Foxglove's OMG IDL decoder names the same view.
  const auto& composited = first["/foxglove/composited"];
  EXPECT_EQ(composited["frame_id"], "view");
  EXPECT_EQ(composited["data"]["format"], "jpeg");
  EXPECT_EQ(composited["data"]["width"], 320);
  EXPECT_EQ(composited["data"]["height"], 240);
  const auto& raw = first["hullpipe/composited_view"];
  EXPECT_EQ(raw["view_width"], 320);
  EXPECT_EQ(raw["eye"], 0) << "the one view (VIEW_EYE_MONO), the field appended last read by Foxglove's decoder";
  EXPECT_EQ(raw["width"], 320);
  EXPECT_GT(raw["frame_seq"].get<int64_t>(), 0);
  EXPECT_GT(first["/foxglove/hull_points"]["data"].get<int>(), 0) << "the hull is in view";
  EXPECT_EQ(first["/foxglove/tf"]["transforms"][0]["parent_frame_id"], "world");
  EXPECT_GE(first["/foxglove/scene"]["entities"].size(), 1u);
  EXPECT_FALSE(first["/foxglove/node_stats"]["node"].get<std::string>().empty());
  bridge->Signal(SIGINT);
  EXPECT_EQ(bridge->Wait(5), 0) << Log("hullpipe_bridge");
  pipeline.Signal(SIGINT);
  pipeline.Wait(30);
}

// A client that subscribes to the camera images and never reads: its queue is
// bounded, its messages past the bound are dropped and counted, and it is told;
// the bridge keeps serving (it stops cleanly).
TEST_F(BridgeProcess, AClientThatNeverReadsIsBoundedAndTold) {
  auto bridge = Start("hullpipe_bridge", {"--port", "0", "--queue-mib", "0.5"});
  const int port = Port();
  ASSERT_GT(port, 0) << Log("hullpipe_bridge");
  // Full-size images until stopped: the kernel's loopback socket buffers (a few
  // MiB) fill before the bridge's queue does, at whatever rate a loaded machine
  // captures.
  auto capture = Start("capture_node", {"--synthetic", "--frames", "100000", "--image-scale", "1"});
  const std::string url = "ws://127.0.0.1:" + std::to_string(port);
  // Subscribes to every image, then stops reading its socket until it is
  // killed: the test waits for the bridge's word, not for a fixed time (a
  // client that left after 6 s on a loaded CI machine was never found slow).
  const std::string script =
      "const W=require('" + js_ + "/node_modules/ws');const w=new W('" + url +
      "',['foxglove.websocket.v1']);w.on('message',(d,bin)=>{if(bin)return;const m=JSON.parse(d);"
      "if(m.op==='advertise'){const c=m.channels.find(c=>c.topic==='hullpipe/camera_image');if(!c)return;"
      "w.send(JSON.stringify({op:'subscribe',subscriptions:[{id:1,channelId:c.id}]}));"
      "setTimeout(()=>w._socket.pause(),300);}});setInterval(()=>{},1000);";  // (a paused socket holds no loop open)
  const std::string log = (dir_ / "slow.log").string();
  launch::Process slow({"/usr/bin/env", "node", "-e", script}, log);
  const double end = MonotonicSeconds() + 60 * test::TimeScale();
  while (Log("hullpipe_bridge").find("reads slower") == std::string::npos && MonotonicSeconds() < end && slow.Running())
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_NE(Log("hullpipe_bridge").find("reads slower"), std::string::npos) << Log("hullpipe_bridge");
  EXPECT_TRUE(slow.Running()) << "the client ended by itself: " << test::ReadFile(log);
  slow.Signal(SIGKILL);  // its connection is reset: the bridge goes on and stops cleanly
  slow.Wait(30);
  EXPECT_EQ(bridge->Stop(), 0) << Log("hullpipe_bridge");
  const std::regex dropped("([0-9]+) dropped for slow clients");
  std::smatch m;
  const std::string text = Log("hullpipe_bridge");
  ASSERT_TRUE(std::regex_search(text, m, dropped)) << text;
  EXPECT_GT(std::stoi(m[1]), 0);
  capture->Stop();
}

// Hostile clients against a live bridge while a good one watches the maps
// (tests/js/hostile_clients.mjs): one subscribing 20,000 times to the images in
// one message, one that never reads, one sending 60 unknown operations of
// 16 KiB and never reading, and 200 handshakes at once with --max-clients 8.
// Before: the first held 1.2 GB and cut the other client's rate from ~30 to
// 2-9 messages/s, the replies of the third grew the bridge by 1.1 GB, and 128
// of the flood got in. Now the flood gets at most the 4 places left, the good
// client keeps at least 0.35 of its rate alone (measured in the same run), and
// the bridge's peak memory stays under 400 MB; it stops cleanly.
TEST_F(BridgeProcess, HostileClientsCostAnotherClientNeitherItsRateNorTheBridgeItsMemory) {
  auto bridge = Start("hullpipe_bridge", {"--port", "0", "--max-clients", "8", "--queue-mib", "1"});
  const int port = Port();
  ASSERT_GT(port, 0) << Log("hullpipe_bridge");
  auto capture = Start("capture_node", {"--synthetic", "--frames", "100000", "--image-scale", "1"});
  const std::string url = "ws://127.0.0.1:" + std::to_string(port);
  const std::string out = (dir_ / "hostile.json").string(), err = (dir_ / "hostile.log").string();
  launch::Process client({"/usr/bin/env", "node", js_ + "/hostile_clients.mjs", url, "hullpipe/object_pixel_map",
                          std::to_string(int(4 * test::TimeScale())), "200"},
                         out, {}, err);
  EXPECT_EQ(client.Wait(120 * test::TimeScale()), 0) << test::ReadFile(err) << Log("hullpipe_bridge");
  const json r = json::parse(test::ReadFile(out), nullptr, false);
  ASSERT_TRUE(r.is_object()) << test::ReadFile(out) << test::ReadFile(err);
  const double alone = r["alone"], hostile = r["hostile"];
  EXPECT_GT(alone, 1.0) << "the positive control: maps reached the good client";
  // At least 0.35 of its rate alone: the hostile clients once left it 2-9 of ~30
  // messages/s (0.07-0.3); this suite runs beside other tests on 2 cores, so a
  // neighbour may take a core in one phase and not the other.
  EXPECT_GE(hostile, 0.35 * alone) << r.dump();
  EXPECT_LE(r["floodOpened"].get<int>(), 4) << r.dump();  // 8 places, 4 taken
  EXPECT_GE(r["floodOpened"].get<int>(), 1) << "the control: the flood was let in up to the bound" << r.dump();
  // The bridge's peak resident memory, while it still runs.
  int64_t peak_kb = -1;
  {
    std::ifstream f("/proc/" + std::to_string(bridge->pid()) + "/status");
    std::string line;
    while (std::getline(f, line))
      if (line.rfind("VmHWM:", 0) == 0) peak_kb = std::atoll(line.c_str() + 6);
  }
  EXPECT_GT(peak_kb, 0);
  EXPECT_LT(peak_kb, 400 * 1024) << "the bridge's peak memory, kB";
  EXPECT_EQ(bridge->Stop(), 0) << Log("hullpipe_bridge");
  EXPECT_NE(Log("hullpipe_bridge").find("--max-clients"), std::string::npos) << "the flood's refusals are logged";
  capture->Stop();
}

}  // namespace
}  // namespace hullpipe
