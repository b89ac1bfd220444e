// hullpipe_bridge: a live view of a running pipeline in Foxglove or Lichtblick,
// over the Foxglove WebSocket protocol (docs/recording.md, "Live view").
//   hullpipe_bridge --domain 7 [--address 127.0.0.1] [--port 8765] [--max-clients 8]
//                   [--queue-mib 16]
// Then in Foxglove: Open connection -> Foxglove WebSocket -> ws://127.0.0.1:8765.
// Advertises every hullpipe topic (cdr, with its type's omgidl schema) and
// streams what each client subscribes to. Its own process rather than a part of
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
#include <memory>
#include <mutex>
#include <random>
#include <thread>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "bridge_state.h"
#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/pipeline/clock.h"
#include "hullpipe/pipeline/node_counters.h"
#include "hullpipe/util/logging.h"
#include "ws_server.h"

using namespace hullpipe;
using namespace hullpipe::dds;
using hullpipe::bridge::WsServer;

int main(int argc, char** argv) {
  hullpipe::LogToStderr("hullpipe_bridge");
  hullpipe::SetCommandLine(argc, argv);
  CLI::App app{"hullpipe_bridge: a live view of the pipeline over the Foxglove WebSocket protocol"};
  CommonOptions common;
  AddCommonOptions(app, common);
  std::string address = "127.0.0.1";
  int port = 8765, max_clients = 8;
  double queue_mib = 16;
  app.add_option("--address", address, "Address to listen on (0.0.0.0: every interface)")->capture_default_str();
  app.add_option("--port", port, "TCP port (0: any free one, logged)")->capture_default_str()->check(CLI::Range(0, 65535));
  app.add_option("--max-clients", max_clients, "Most clients at once")->capture_default_str()->check(CLI::Range(1, 64));
  app.add_option("--queue-mib", queue_mib, "Most MiB queued for one client before its messages are dropped")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 1024.0));
  CLI11_PARSE(app, argc, argv);
  try {
    auto participant = StartNode("bridge", common);
    std::vector<bridge::Channel> channels;
    const auto& types = KnownTypes();
    for (size_t i = 0; i < types.size(); ++i)
      channels.push_back({uint32_t(i + 1), types[i].topic_name, "cdr", types[i].type_name, IdlText(), "omgidl"});
    bridge::BridgeState state(channels, max_clients, "hullpipe_bridge");
    SystemClock clock;
    NodeCounters counters(clock);
    NodeReporter reporter(*participant, "bridge", counters);
    const size_t queue_bytes = size_t(queue_mib * (1 << 20));

    std::mutex mu;
    std::map<uint64_t, uint64_t> dropped;  // per client
    std::mt19937_64 rng(std::random_device{}());
    WsServer* server_ptr = nullptr;
    auto send = [&](const bridge::Outgoing& o) {
      const auto r = server_ptr->Send(o.client, o.binary, o.payload, o.binary ? queue_bytes : 0);
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
    handlers.accept = [&](const std::vector<std::string>& protocols, std::string* why) {
      const std::string p = state.Accept(protocols, why);
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
    WsServer server(handlers);
    server_ptr = &server;
    const int bound = server.Start(address, port);
    spdlog::info("listening on ws://{}:{} (Foxglove: Open connection -> Foxglove WebSocket)", address, bound);

    // DDS: a reader per wanted channel, made when the first client subscribes
    // and removed when the last one leaves.
    std::map<uint32_t, std::unique_ptr<CdrReader>> readers;
    while (!StopRequested()) {
      const auto wanted = state.Wanted();
      for (auto it = readers.begin(); it != readers.end();)
        it = wanted.count(it->first) ? std::next(it) : readers.erase(it);
      for (uint32_t ch : wanted)
        if (!readers.count(ch)) {
          const KnownType& kt = types[ch - 1];
          // Best-effort for streams (writers never wait for the bridge); reliable
          // and transient-local where the topic is (calibration, stats): its
          // history reaches a client that subscribes late.
          const QosSpec qos{kt.qos.transient_local, kt.qos.transient_local, 1};
          readers[ch] = std::make_unique<CdrReader>(*participant, kt, qos);
        }
      size_t n = 0;
      for (auto& [ch, reader] : readers) {
        const uint32_t channel = ch;
        n += reader->TakeEach([&](const std::vector<uint8_t>& bytes, int64_t) {
          counters.FrameIn();
          for (const auto& o : state.Route(channel, uint64_t(NowNs()), bytes)) send(o);
          counters.FrameOut(0);
        });
      }
      reporter.Publish();
      if (n == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    server.Stop();
    reporter.Publish(true);
    spdlog::info("stopped: {} samples in, {} dropped for slow clients", counters.frames_in(), counters.dropped());
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
