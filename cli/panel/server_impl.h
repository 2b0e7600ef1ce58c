// Inside the panel's server (cli/panel/server.h), what its two halves share: the transport
// (server.cpp: sockets, connections, viewers, the live stream) and the routes (routes.cpp: the
// checks on a request and the API). Not part of any API.
#pragma once

#include <atomic>
#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <nlohmann/json.hpp>

#include "cli/panel/server.h"

namespace machplan::panel {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;

// A request as the routes see it: its head (read before anything else is decided) and, once
// the route has allowed it, its body.
struct Request {
  std::string method;
  std::string path;  // the target without its query
  http::fields fields;
  std::optional<std::uint64_t> content_length;  // as announced (none: no body, or chunked)
  std::string body;

  std::string header(std::string_view name) const {
    const auto it = fields.find(beast::string_view(name.data(), name.size()));
    return it == fields.end() ? std::string() : std::string(it->value());
  }
};

struct Reply {
  Reply() = default;
  Reply(int c, std::string b, std::string t = "application/json", std::string h = {})
      : code(c), body(std::move(b)), type(std::move(t)), headers(std::move(h)) {}
  int code = 200;
  std::string body;
  std::string type = "application/json";
  std::string headers;  // extra, each ending in \r\n
};

// A JSON answer {"error": message} with the code.
Reply error(int code, const std::string& message);
// A JSON answer with 200.
Reply ok(const nlohmann::json& j);

class Connection;
class Viewer;

// Threads: one I/O thread runs every socket (accepting, reading heads and bodies, writing
// answers and live frames) without ever blocking; requests run on `workers`, except the E-stop
// and the status, which have a thread each (`estop_lane`, `status_lane`) so that no request,
// however slow, is ever ahead of them; one more thread paces the live stream.
struct Server::Impl {
  Panel& panel;
  ServerOptions o;
  std::string token;
  std::map<std::string, std::string> files;  // the page: name -> bytes

  std::mutex control_mutex;
  std::string controller;  // the client that holds control ("" : nobody)

  // Connections by peer, and those still sending their head, oldest first: a peer (or the
  // server) at its limit makes room by closing its oldest unfinished head.
  std::mutex connections_mutex;
  std::map<std::string, int> per_peer;
  int open_connections = 0;
  std::list<std::weak_ptr<Connection>> heading;
  std::atomic<std::uint64_t> evicted{0}, refused{0};

  std::mutex viewers_mutex;
  std::list<std::shared_ptr<Viewer>> viewers;
  std::atomic<std::uint64_t> frames{0}, skipped_gone{0}, sent_gone{0};
  std::atomic<bool> streaming{true};
  std::thread streamer;

  // Declared last, stopped first (~Server): what their handlers hold refers to the above.
  asio::io_context ioc{1};
  tcp::acceptor acceptor{ioc};
  asio::steady_timer accept_pause{ioc};
  asio::thread_pool workers, estop_lane{1}, status_lane{1};
  std::thread io_thread;
  int port = 0;

  Impl(Panel& p, ServerOptions opt) : panel(p), o(std::move(opt)), workers(static_cast<std::size_t>(o.threads)) {}

  void listen();
  void accept();
  void admit(tcp::socket socket);
  bool host_allowed(const Request& q) const;
  std::optional<Reply> before_body(const Request& q, std::size_t& body_limit);
  Reply after_body(const Request& q);
  Reply api(const Request& q, const std::string& path, const nlohmann::json& body);
  Reply serve_file(const Request& q) const;
  std::optional<Reply> authorize(const Request& q, bool& by_cookie);
  std::optional<Reply> ws_refusal(const Request& q);
  bool holds_control(const Request& q);
  void stream();
};

}  // namespace machplan::panel
