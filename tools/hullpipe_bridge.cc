// hullpipe_bridge: a live view of a running pipeline in Foxglove or Lichtblick,
// over the Foxglove WebSocket protocol (docs/recording.md, "Live view").
//   hullpipe_bridge --domain 7 [--address 127.0.0.1] [--port 8765] [--max-clients 8]
//                   [--queue-mib 16]
// Then in Foxglove: Open connection -> Foxglove WebSocket -> ws://127.0.0.1:8765.
// Advertises every hullpipe topic (cdr, with its type's omgidl schema) and the
// viewable channels of hullpipe/foxglove/channels.h (Foxglove's well-known schemas, JSON:
// camera images, object-pixel maps, calibrations and transforms, the composited
// view and its hull points, the scene, node rates; a camera's channels from when
// its calibration arrives), and streams what each client subscribes to. A
// viewable channel costs only while someone watches it (its JPEG or PNG encode
// runs for subscribers alone); calibrations, transforms and model parts are
// latched, so a client that comes late still sees the rig. Its own process rather than a part of
// render_node: the compositor's loop never waits on a socket, and the bridge
// reads a DDS topic only while some client is subscribed to it (best-effort,
// depth 1, so the writers never wait for the bridge). A client that reads slower
// than the topic arrives has at most --queue-mib queued; past that its messages
// are dropped, counted (NodeStats "bridge": dropped) and it is told once by a
// status message. Clients cannot publish. Listens on loopback unless --address
// says otherwise. Stops within a second of SIGINT.
#include <chrono>
#include <cstdio>
#include <map>
#include <optional>
#include <memory>
#include <mutex>
#include <random>
#include <set>
#include <thread>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/foxglove/bridge_channels.h"
#include "hullpipe/foxglove/bridge_state.h"
#include "hullpipe/foxglove/channels.h"
#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/pipeline/clock.h"
#include "hullpipe/pipeline/node_counters.h"
#include "hullpipe/util/logging.h"
#include "hullpipe/foxglove/ws_server.h"

using namespace hullpipe;
using namespace hullpipe::dds;
using hullpipe::bridge::WsServer;

int main(int argc, char** argv) {
  CLI::App app{"hullpipe_bridge: a live view of the pipeline over the Foxglove WebSocket protocol"};
  CommonOptions common;
  OpenCommandLine(argc, argv, "hullpipe_bridge", app, common);
  std::string address = "127.0.0.1";
  int port = 8765, max_clients = 8;
  double queue_mib = 16;
  app.add_option("--address", address, "Address to listen on (0.0.0.0: every interface)")->capture_default_str();
  app.add_option("--port", port, "TCP port (0: any free one, logged)")
      ->capture_default_str()
      ->check(CLI::Range(0, 65535));
  app.add_option("--max-clients", max_clients, "Most clients at once")->capture_default_str()->check(CLI::Range(1, 64));
  app.add_option("--queue-mib", queue_mib, "Most MiB queued for one client before its messages are dropped")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 1024.0));
  CLI11_PARSE(app, argc, argv);
  try {
    auto participant = StartNode("bridge", common);
    // The channels (foxglove/bridge_channels.h), used on this (the DDS) thread only.
    const auto& types = KnownTypes();
    foxglove::BridgeChannels table(types);
    bridge::BridgeState state(table.channels(), max_clients, "hullpipe_bridge");
    SystemClock clock;
    NodeCounters counters(clock);
    NodeReporter reporter(*participant, "bridge", counters);
    const size_t queue_bytes = size_t(queue_mib * (1 << 20));

    std::mutex mu;
    std::map<uint64_t, uint64_t> dropped;  // per client
    std::mt19937_64 rng(std::random_device{}());
    WsServer* server_ptr = nullptr;
    // Replies (status, advertise) count against the queue bound as data does: a
    // client that sent 60 unknown operations and never read once held 1.1 GB.
    auto send = [&](const bridge::Outgoing& o) {
      const auto r = server_ptr->Send(o.client, o.binary, o.payload, queue_bytes);
      if (r != WsServer::Sent::kQueueFull) return;
      counters.Dropped();
      std::lock_guard<std::mutex> lock(mu);
      if (dropped[o.client]++ == 0) {
        spdlog::warn("client {} reads slower than its topics arrive: dropping its messages past {:.1f} MiB queued",
                     o.client, queue_mib);
        const auto st = bridge::BridgeState::Status(o.client, 1, "hullpipe_bridge: you read slower than the "
                                                                 "topics arrive; messages past the queue bound are "
                                                                 "dropped");
        server_ptr->Send(o.client, false, st.payload);
      }
    };
    WsServer::Handlers handlers;
    handlers.accept = [&](const std::vector<std::string>& protocols, int handshaking, std::string* why) {
      const std::string p = state.Accept(protocols, handshaking, why);
      if (p.empty()) spdlog::warn("refused a client: {}", *why);
      return p;
    };
    handlers.open = [&](uint64_t id, const std::string& remote, const std::string& proto) {
      char session[17];
      {
        std::lock_guard<std::mutex> lock(mu);
        std::snprintf(session, sizeof session, "%016llx", (unsigned long long)rng());
      }
      for (const auto& o : state.Open(id, session)) send(o);
      spdlog::info("client {} connected from {} ({})", id, remote, proto);
    };
    handlers.close = [&](uint64_t id) {
      state.Close(id);
      std::lock_guard<std::mutex> lock(mu);
      spdlog::info("client {} left{}", id,
                   dropped[id] ? fmt::format("; {} of its messages were dropped", dropped[id]) : std::string());
    };
    handlers.message = [&](uint64_t id, bool binary, const std::string& payload) {
      if (binary) {
        send(bridge::BridgeState::Status(id, 2, "client publishing is not enabled on this bridge"));
        return;
      }
      for (const auto& o : state.OnText(id, payload)) send(o);
    };
    WsServer server(handlers, bridge::BridgeState::kMaxTextBytes);
    server_ptr = &server;
    const int bound = server.Start(address, port);
    spdlog::info("listening on ws://{}:{} (Foxglove: Open connection -> Foxglove WebSocket)", address, bound);

    // The viewable channels' derivation. A camera's channels are advertised
    // when its calibration first arrives (at most BridgeChannels::kMaxCameras
    // cameras: further camera ids are counted as rejected and named once).
    std::set<uint32_t> wanted;  // channels some client is subscribed to (refreshed each pass)
    const auto sink = [&](foxglove::Message m) {
      std::vector<bridge::Channel> added;
      const uint64_t refused = table.refused();
      const std::optional<uint32_t> channel = table.ChannelOf(m.topic, &added);
      if (!added.empty())
        for (const auto& o : state.Advertise(added)) send(o);
      if (table.refused() > refused) {
        counters.Rejected();
        if (refused == 0)
          spdlog::warn("camera {} is past the bridge's {} cameras: its viewable channels are not advertised",
                       table.first_refused_camera(), foxglove::BridgeChannels::kMaxCameras);
      }
      if (!channel) return;
      const std::vector<uint8_t> bytes(m.json.begin(), m.json.end());
      const uint64_t now = uint64_t(NowNs());
      if (!m.latch_key.empty()) state.Latch(*channel, m.latch_key, now, bytes);
      for (const auto& o : state.Route(*channel, now, bytes)) send(o);
    };
    foxglove::Deriver deriver(*participant, sink,
                              [&](const std::string& topic) { return table.IsWanted(topic, wanted); });

    // DDS: the calibration always (the cameras' channels and latched state come
    // from it; reliable, transient-local, one sample per camera), and a reader
    // per type some subscribed channel needs, made when the first client
    // subscribes and removed when the last one leaves.
    const KnownType& info_type = types[table.camera_info()];
    CdrReader calibration(*participant, info_type, QosSpec{true, true, 1});
    std::map<size_t, std::unique_ptr<CdrReader>> readers;  // by type index
    while (!StopRequested()) {
      wanted = state.Wanted();
      const foxglove::BridgeChannels::Needs needs = table.ReadersFor(wanted);
      const std::set<size_t>& raw = needs.raw;
      const std::set<size_t>& derived = needs.derived;
      for (auto it = readers.begin(); it != readers.end();)
        it = needs.all.count(it->first) ? std::next(it) : readers.erase(it);
      for (size_t t : needs.all)
        if (!readers.count(t)) {
          const KnownType& kt = types[t];
          // Best-effort for streams (writers never wait for the bridge); reliable
          // and transient-local where the topic is (calibration, stats, model
          // parts): its history reaches a client that subscribes late.
          const QosSpec qos{kt.qos.transient_local, kt.qos.transient_local, 1};
          readers[t] = std::make_unique<CdrReader>(*participant, kt, qos);
        }
      size_t n = calibration.TakeEach([&](const std::vector<uint8_t>& bytes, int64_t) {
        if (!deriver.Add(info_type.type_name, bytes, NowNs())) counters.Rejected();
      });
      for (auto& [t, reader] : readers) {
        const size_t type = t;
        n += reader->TakeEach([&](const std::vector<uint8_t>& bytes, int64_t) {
          counters.FrameIn();
          if (raw.count(type))
            for (const auto& o : state.Route(uint32_t(type + 1), uint64_t(NowNs()), bytes)) send(o);
          if (derived.count(type) && !deriver.Add(types[type].type_name, bytes, NowNs())) counters.Rejected();
          counters.FrameOut(0);
        });
      }
      reporter.Publish();
      if (n == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    server.Stop();
    reporter.Publish(true);
    spdlog::info("stopped: {} samples in, {} dropped for slow clients, {} refused", counters.frames_in(),
                 counters.dropped(), counters.rejected());
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
