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

#include "bridge_state.h"
#include "hullpipe/geometry/conventions.h"
#include "test_util.h"

namespace hullpipe {
namespace {

using bridge::BridgeState;
using bridge::Channel;
using nlohmann::json;

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
  EXPECT_EQ(s.Accept({"foxglove.websocket.v1"}, &why), "foxglove.websocket.v1");
  EXPECT_EQ(s.Accept({"foxglove.websocket.v1", "foxglove.sdk.v1"}, &why), "foxglove.sdk.v1");
  EXPECT_EQ(s.Accept({"chat"}, &why), "");
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
  EXPECT_EQ(s.Accept({"foxglove.websocket.v1"}, &why), "");
  EXPECT_NE(why.find("--max-clients"), std::string::npos);
  s.Close(8);
  EXPECT_EQ(s.Accept({"foxglove.websocket.v1"}, &why), "foxglove.websocket.v1");
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

// A client that subscribes to the camera images and never reads: its queue is
// bounded, its messages past the bound are dropped and counted, and it is told;
// the bridge keeps serving (it stops cleanly).
TEST_F(BridgeProcess, AClientThatNeverReadsIsBoundedAndTold) {
  auto bridge = Start("hullpipe_bridge", {"--port", "0", "--queue-mib", "0.5"});
  const int port = Port();
  ASSERT_GT(port, 0) << Log("hullpipe_bridge");
  auto capture = Start("capture_node", {"--synthetic", "--frames", "200"});
  const std::string url = "ws://127.0.0.1:" + std::to_string(port);
  // Subscribes to every image, then stops reading its socket for 6 s.
  const std::string script =
      "const W=require('" + js_ + "/node_modules/ws');const w=new W('" + url +
      "',['foxglove.websocket.v1']);w.on('message',(d,bin)=>{if(bin)return;const m=JSON.parse(d);"
      "if(m.op==='advertise'){const c=m.channels.find(c=>c.topic==='hullpipe/camera_image');"
      "w.send(JSON.stringify({op:'subscribe',subscriptions:[{id:1,channelId:c.id}]}));"
      "setTimeout(()=>w._socket.pause(),300);setTimeout(()=>process.exit(0),6000);}});";
  const std::string log = (dir_ / "slow.log").string();
  launch::Process slow({"/usr/bin/env", "node", "-e", script}, log);
  const double end = MonotonicSeconds() + 30;
  while (Log("hullpipe_bridge").find("reads slower") == std::string::npos && MonotonicSeconds() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_NE(Log("hullpipe_bridge").find("reads slower"), std::string::npos) << Log("hullpipe_bridge");
  EXPECT_EQ(slow.Wait(30), 0) << test::ReadFile(log);
  EXPECT_EQ(bridge->Stop(), 0) << Log("hullpipe_bridge");
  const std::regex dropped("([0-9]+) dropped for slow clients");
  std::smatch m;
  const std::string text = Log("hullpipe_bridge");
  ASSERT_TRUE(std::regex_search(text, m, dropped)) << text;
  EXPECT_GT(std::stoi(m[1]), 0);
  capture->Stop();
}

}  // namespace
}  // namespace hullpipe
