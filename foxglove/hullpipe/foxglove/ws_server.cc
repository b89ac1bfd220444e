#include "hullpipe/foxglove/ws_server.h"

#include <map>
#include <set>
#include <mutex>
#include <stdexcept>
#include <thread>

#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

namespace hullpipe::bridge {

using Server = websocketpp::server<websocketpp::config::asio>;

struct WsServer::Impl {
  Handlers h;
  Server server;
  std::thread io;
  std::mutex mu;
  std::map<uint64_t, websocketpp::connection_hdl> hdls;
  // Handshakes accepted, not yet open (or failed).
  std::set<websocketpp::connection_hdl, std::owner_less<websocketpp::connection_hdl>> handshaking;
  uint64_t next = 1;
  bool running = false;
};

WsServer::WsServer(Handlers handlers, size_t max_message_bytes) : impl_(std::make_unique<Impl>()) {
  impl_->h = std::move(handlers);
  Server& s = impl_->server;
  s.clear_access_channels(websocketpp::log::alevel::all);
  s.clear_error_channels(websocketpp::log::elevel::all);
  s.init_asio();
  s.set_reuse_addr(true);
  s.set_max_message_size(max_message_bytes);
  Impl* impl = impl_.get();
  s.set_validate_handler([impl](websocketpp::connection_hdl hdl) {
    auto con = impl->server.get_con_from_hdl(hdl);
    std::string why;
    int handshaking;
    {
      std::lock_guard<std::mutex> lock(impl->mu);
      handshaking = int(impl->handshaking.size());
    }
    const std::string proto = impl->h.accept(con->get_requested_subprotocols(), handshaking, &why);
    if (proto.empty()) {
      con->set_status(websocketpp::http::status_code::service_unavailable, why);
      return false;
    }
    con->select_subprotocol(proto);
    std::lock_guard<std::mutex> lock(impl->mu);
    impl->handshaking.insert(hdl);
    return true;
  });
  // A handshake that fails after it was accepted (the client left) frees its place.
  s.set_fail_handler([impl](websocketpp::connection_hdl hdl) {
    std::lock_guard<std::mutex> lock(impl->mu);
    impl->handshaking.erase(hdl);
  });
  s.set_open_handler([impl](websocketpp::connection_hdl hdl) {
    auto con = impl->server.get_con_from_hdl(hdl);
    uint64_t id;
    {
      std::lock_guard<std::mutex> lock(impl->mu);
      impl->handshaking.erase(hdl);
      id = impl->next++;
      impl->hdls[id] = hdl;
    }
    con->set_close_handler([impl, id](websocketpp::connection_hdl) {
      {
        std::lock_guard<std::mutex> lock(impl->mu);
        impl->hdls.erase(id);
      }
      impl->h.close(id);
    });
    con->set_fail_handler([impl, id](websocketpp::connection_hdl) {
      {
        std::lock_guard<std::mutex> lock(impl->mu);
        impl->hdls.erase(id);
      }
      impl->h.close(id);
    });
    con->set_message_handler([impl, id](websocketpp::connection_hdl, Server::message_ptr m) {
      impl->h.message(id, m->get_opcode() == websocketpp::frame::opcode::binary, m->get_payload());
    });
    impl->h.open(id, con->get_remote_endpoint(), con->get_subprotocol());
  });
}

WsServer::~WsServer() { Stop(); }

int WsServer::Start(const std::string& address, int port) {
  websocketpp::lib::error_code ec;
  asio::error_code aec;
  const auto ip = asio::ip::make_address(address, aec);
  if (aec) throw std::runtime_error("--address " + address + ": " + aec.message());
  impl_->server.listen(asio::ip::tcp::endpoint(ip, uint16_t(port)), ec);
  if (ec) throw std::runtime_error("--address " + address + " --port " + std::to_string(port) + ": " + ec.message());
  impl_->server.start_accept(ec);
  if (ec) throw std::runtime_error("accept on " + address + ": " + ec.message());
  const auto local = impl_->server.get_local_endpoint(ec);
  impl_->running = true;
  impl_->io = std::thread([this] { impl_->server.run(); });
  return ec ? port : int(local.port());
}

WsServer::Sent WsServer::Send(uint64_t client, bool binary, const std::string& payload, size_t max_buffered) {
  websocketpp::connection_hdl hdl;
  {
    std::lock_guard<std::mutex> lock(impl_->mu);
    const auto it = impl_->hdls.find(client);
    if (it == impl_->hdls.end()) return Sent::kGone;
    hdl = it->second;
  }
  websocketpp::lib::error_code ec;
  auto con = impl_->server.get_con_from_hdl(hdl, ec);
  if (ec) return Sent::kGone;
  if (max_buffered > 0 && con->get_buffered_amount() > max_buffered) return Sent::kQueueFull;
  ec = con->send(payload, binary ? websocketpp::frame::opcode::binary : websocketpp::frame::opcode::text);
  return ec ? Sent::kGone : Sent::kSent;
}

void WsServer::Stop() {
  if (!impl_->running) return;
  impl_->running = false;
  websocketpp::lib::error_code ec;
  impl_->server.stop_listening(ec);
  {
    std::lock_guard<std::mutex> lock(impl_->mu);
    for (const auto& [id, hdl] : impl_->hdls)
      impl_->server.close(hdl, websocketpp::close::status::going_away, "server stopping", ec);
  }
  impl_->server.stop();
  if (impl_->io.joinable()) impl_->io.join();
}

}  // namespace hullpipe::bridge
