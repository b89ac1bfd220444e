// A WebSocket server (websocketpp on standalone asio) behind a plain interface, so
// that websocketpp's headers (C++17 only: its templates are ill-formed C++20) stay
// in one translation unit. Used by hullpipe_bridge.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace hullpipe::bridge {

class WsServer {
 public:
  /// Called on the server's own thread.
  struct Handlers {
    /// The subprotocol to select among those a client asks for, or "" to refuse
    /// it (HTTP 503) with *why logged by the caller. `handshaking`: clients
    /// accepted here whose connection has not opened yet (they count against a
    /// bound on clients as the open ones do).
    std::function<std::string(const std::vector<std::string>& subprotocols, int handshaking, std::string* why)>
        accept;
    std::function<void(uint64_t client, const std::string& remote, const std::string& subprotocol)> open;
    std::function<void(uint64_t client)> close;
    std::function<void(uint64_t client, bool binary, const std::string& payload)> message;
  };
  /// Messages from clients over `max_message_bytes` close their connection
  /// (status 1009) before they are buffered whole.
  explicit WsServer(Handlers handlers, size_t max_message_bytes = size_t(1) << 20);
  ~WsServer();  ///< Stop()s.
  WsServer(const WsServer&) = delete;
  WsServer& operator=(const WsServer&) = delete;
  /// Listens on address:port (port 0: any free one) and starts serving on a
  /// thread of its own; returns the port. Throws std::runtime_error naming the
  /// address and port if it cannot.
  int Start(const std::string& address, int port);
  enum class Sent { kSent, kGone, kQueueFull };
  /// Queues a message for one client (any thread). With max_buffered > 0, a
  /// client with more than that many bytes already queued gets nothing (kQueueFull).
  Sent Send(uint64_t client, bool binary, const std::string& payload, size_t max_buffered = 0);
  /// Closes every connection and stops the thread (idempotent).
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hullpipe::bridge
