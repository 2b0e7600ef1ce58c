#include "cli/panel/server.h"

#include <malloc.h>
#include <sys/random.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <list>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "engine/common/error.h"
#include "engine/common/names.h"
#include "engine/common/internal/text_scan.h"
#include "engine/common/output_file.h"
#include "engine/common/stop.h"
#include "engine/executor/guard.h"

namespace machplan::panel {

namespace fs = std::filesystem;
namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using nlohmann::json;

void ServerOptions::validate() const {
  require_field(port >= 0 && port <= 65535, "port", port, "must be in 0 .. 65535");
  require_field(!bind.empty() && bind.find_first_of(",: \t") == std::string::npos, "bind", fmt::format("'{}'", excerpt(bind)),
                "is not an IPv4 address or host name");
  require_field(std::isfinite(frame_hz) && frame_hz >= 30 && frame_hz <= 200, "frame_hz", frame_hz, "must be in 30 .. 200");
  require_field(max_viewers >= 1 && max_viewers <= 1000, "max_viewers", max_viewers, "must be in 1 .. 1000");
  require_field(threads >= 1 && threads <= 256, "threads", threads, "must be in 1 .. 256");
  require_field(std::isfinite(head_timeout_s) && head_timeout_s >= 0.1 && head_timeout_s <= 600, "head_timeout_s",
                head_timeout_s, "must be in 0.1 .. 600");
  require_field(std::isfinite(body_timeout_s) && body_timeout_s >= 1 && body_timeout_s <= 3600, "body_timeout_s",
                body_timeout_s, "must be in 1 .. 3600");
  require_field(max_connections >= 16 && max_connections <= 100000, "max_connections", max_connections,
                "must be in 16 .. 100000");
  require_field(max_connections_per_peer >= 4 && max_connections_per_peer <= max_connections, "max_connections_per_peer",
                max_connections_per_peer, "must be in 4 .. max_connections");
}

std::string random_token() {
  unsigned char bytes[32];
  std::size_t have = 0;
  while (have < sizeof bytes) {
    const ssize_t n = getrandom(bytes + have, sizeof bytes - have, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw InternalError("getrandom failed: no token can be made");
    have += static_cast<std::size_t>(n);
  }
  std::string t;
  for (unsigned char b : bytes) t += fmt::format("{:02x}", b);
  return t;
}

std::string web_root_folder() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  std::vector<fs::path> candidates;
  // An installed machplan: the page beside it (PREFIX/bin/../share/machplan/panel), so that an
  // installed tree can be moved; then the prefix it was configured for.
  if (!ec) candidates.push_back(exe.parent_path().parent_path() / "share" / "machplan" / "panel");
#ifdef MACHPLAN_INSTALL_DATADIR
  candidates.push_back(fs::path(MACHPLAN_INSTALL_DATADIR) / "panel");
#endif
  // A program of this build tree (the CLI, the tests, the bench) serves the source tree's page;
  // an installed one never does, so that a page missing from the install is seen.
#if defined(MACHPLAN_SOURCE_DIR) && defined(MACHPLAN_BUILD_DIR)
  if (!ec && exe.lexically_normal().string().rfind(fs::path(MACHPLAN_BUILD_DIR "/").lexically_normal().string(), 0) == 0)
    candidates.push_back(fs::path(MACHPLAN_SOURCE_DIR) / "cli" / "panel" / "web");
#endif
  for (const fs::path& c : candidates)
    if (fs::is_regular_file(c / "index.html", ec)) return c.string();
  return {};
}

namespace {

bool is_loopback(const std::string& bind) {
  return bind == "127.0.0.1" || bind == "localhost" || bind.rfind("127.", 0) == 0;
}

// Constant time in the length of `expected`.
bool same_token(const std::string& given, const std::string& expected) {
  unsigned char diff = given.size() == expected.size() ? 0 : 1;
  for (std::size_t i = 0; i < expected.size(); ++i) diff |= static_cast<unsigned char>(expected[i] ^ (i < given.size() ? given[i] : 0));
  return diff == 0;
}

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

Request request_of(const http::request_parser<http::string_body>& parser) {
  const auto& m = parser.get();
  Request q;
  q.method = std::string(m.method_string());
  const std::string target(m.target());
  q.path = target.substr(0, target.find('?'));
  q.fields = static_cast<const http::fields&>(m);
  if (const auto n = parser.content_length()) q.content_length = *n;
  return q;
}

// The token of a request: the bearer header, else the login cookie. `by_cookie` says which.
std::string request_token(const Request& q, bool& by_cookie) {
  by_cookie = false;
  const std::string auth = q.header("Authorization");
  if (auth.size() > 7 && strncasecmp(auth.c_str(), "Bearer ", 7) == 0) return auth.substr(7);
  const std::string cookies = q.header("Cookie");
  const std::string key = "machplan_token=";
  for (std::size_t at = 0; (at = cookies.find(key, at)) != std::string::npos; at += key.size()) {
    if (at != 0 && cookies[at - 1] != ' ' && cookies[at - 1] != ';') continue;
    const std::size_t end = cookies.find(';', at);
    by_cookie = true;
    return cookies.substr(at + key.size(), end == std::string::npos ? std::string::npos : end - at - key.size());
  }
  return {};
}

struct Reply {
  Reply() = default;
  Reply(int c, std::string b, std::string t = "application/json", std::string h = {})
      : code(c), body(std::move(b)), type(std::move(t)), headers(std::move(h)) {}
  int code = 200;
  std::string body;
  std::string type = "application/json";
  std::string headers;  // extra, each ending in \r\n
};

const char* reason(int code) {
  switch (code) {
    case 200: return "OK";
    case 400: return "Bad Request";
    case 401: return "Unauthorized";
    case 403: return "Forbidden";
    case 404: return "Not Found";
    case 405: return "Method Not Allowed";
    case 409: return "Conflict";
    case 413: return "Payload Too Large";
    case 415: return "Unsupported Media Type";
    case 431: return "Request Header Fields Too Large";
    case 422: return "Unprocessable Content";
    case 500: return "Internal Server Error";
    case 503: return "Service Unavailable";
    case 507: return "Insufficient Storage";
  }
  return "Status";
}

// The answer's bytes: head and body (none for HEAD). Every answer closes its connection.
std::string bytes_of(const Reply& r, bool head_only) {
  std::string out = fmt::format(
      "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n"
      "X-Content-Type-Options: nosniff\r\nX-Frame-Options: DENY\r\nReferrer-Policy: no-referrer\r\nConnection: close\r\n{}\r\n",
      r.code, reason(r.code), r.type, r.body.size(), r.headers);
  if (!head_only) out += r.body;
  return out;
}

Reply error(int code, const std::string& message) {
  return {code, json{{"error", message}}.dump(-1, ' ', false, json::error_handler_t::replace) + "\n"};
}

Reply ok(const json& j) { return {200, j.dump(-1, ' ', false, json::error_handler_t::replace) + "\n"}; }

// A number member, or nullopt when absent; 400 text for a wrong type.
// body[key] as a whole number in lo .. hi (`what` names it in the refusal); none when absent or null.
std::optional<int> whole_number(const json& body, const char* key, long long lo, long long hi, const char* what) {
  if (!body.contains(key) || body[key].is_null()) return std::nullopt;
  if (!body[key].is_number_integer()) throw InputError::field(key, "must be a whole number");
  // Above the largest signed 64-bit number JSON gives an unsigned one: read as such, so the
  // message quotes it as sent (as signed it would wrap to a negative number).
  if (body[key].is_number_unsigned() && body[key].get<unsigned long long>() > static_cast<unsigned long long>(hi))
    throw InputError::field(key, fmt::format("{} is not a {} ({} to {})", body[key].get<unsigned long long>(), what, lo, hi));
  const long long v = body[key].get<long long>();
  if (v < lo || v > hi) throw InputError::field(key, fmt::format("{} is not a {} ({} to {})", v, what, lo, hi));
  return static_cast<int>(v);
}

std::optional<double> number(const json& body, const char* key) {
  if (!body.contains(key) || body[key].is_null()) return std::nullopt;
  if (!body[key].is_number()) throw InputError::field(key, "must be a number");
  return body[key].get<double>();
}

// Every API route with the methods it takes (docs/panel.md's table; any other method is 405)
// and whether a POST needs the client in control.
struct ApiRoute {
  const char* path;
  bool get, post, post_needs_control;
};
constexpr ApiRoute kApiRoutes[] = {
    {"/status", true, false, false},  {"/login", false, true, false},   {"/control", false, true, false},
    {"/job", true, true, true},       {"/run", false, true, true},      {"/hold", false, true, true},
    {"/resume", false, true, true},   {"/stop", false, true, true},     {"/estop", false, true, false},
    {"/reset", false, true, true},    {"/override", false, true, true}, {"/recover", false, true, true},
    {"/thc", false, true, true},      {"/jog", false, true, true},      {"/report", true, false, false},
    {"/guard", true, true, true},     {"/history", true, false, false}};

const ApiRoute* find_api_route(const std::string& path) {
  for (const ApiRoute& r : kApiRoutes)
    if (path == r.path) return &r;
  return nullptr;
}

// Deeper JSON than this is refused before it is parsed: no request of the API nests more than
// three levels, and a parser's memory grows with the nesting (a 32 MB body of '[' would make
// millions of nodes).
constexpr int kMaxJsonDepth = 64;

constexpr const char* kTakeControlFirst = "another client holds control, or none does: take control first (POST /api/control)";

// Whether `text` opens more than `max_depth` arrays or objects inside one another, counted on
// the bytes (brackets inside strings do not count): O(n), no allocation.
bool json_nested_deeper_than(std::string_view text, int max_depth) {
  int depth = 0;
  bool in_string = false, escaped = false;
  for (const char ch : text) {
    if (in_string) {
      if (escaped) escaped = false;
      else if (ch == '\\') escaped = true;
      else if (ch == '"') in_string = false;
    } else if (ch == '"') {
      in_string = true;
    } else if (ch == '[' || ch == '{') {
      if (++depth > max_depth) return true;
    } else if (ch == ']' || ch == '}') {
      --depth;
    }
  }
  return false;
}

class Connection;
class Viewer;

}  // namespace

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
  Reply api(const Request& q, const std::string& path, const json& body);
  Reply serve_file(const Request& q) const;
  std::optional<Reply> authorize(const Request& q, bool& by_cookie);
  std::optional<Reply> ws_refusal(const Request& q);
  bool holds_control(const Request& q);
  void stream();
};

namespace {

// One client connection, from its accept to its close, on the I/O thread: the head within
// head_timeout_s, the checks that need only the head, the body within body_timeout_s, the
// request on its lane, the answer, then a lingering close (the client reads the whole answer
// even when its body was refused unread). A WebSocket upgrade of /api/live becomes a Viewer.
class Connection : public std::enable_shared_from_this<Connection> {
 public:
  Connection(Server::Impl& s, tcp::socket socket, std::string peer) : s_(s), stream_(std::move(socket)), peer_(std::move(peer)) {}
  ~Connection() { release(); }

  // Counts the connection for its peer and lists it as sending its head (connections_mutex held).
  void enlist(std::list<std::weak_ptr<Connection>>::iterator at) {
    listed_ = true;
    in_heading_ = at;
  }
  const std::string& peer() const { return peer_; }

  void start() {
    parser_.emplace();
    parser_->header_limit(kHeadBytes);
    // The route's limit is set once the head is read (before_body refuses a larger announced
    // length); until then Beast's own default (1 MiB) must not refuse a body first.
    parser_->body_limit(std::numeric_limits<std::uint64_t>::max());
    stream_.expires_after(seconds(s_.o.head_timeout_s));
    http::async_read_header(stream_, buffer_, *parser_,
                            [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_head(ec); });
  }

  // Closed to make room for another (I/O thread): its pending read ends, and so does it.
  void evict() {
    release();
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_both, ignored);
    stream_.socket().close(ignored);
  }

  // Called by the lanes when the answer is ready (any thread).
  void answer(Reply r) {
    asio::post(stream_.get_executor(), [self = shared_from_this(), r = std::move(r)]() mutable { self->write(std::move(r)); });
  }

  // Off the peer's count and the list of unfinished heads; idempotent (connections_mutex free).
  void release() {
    const std::lock_guard<std::mutex> lock(s_.connections_mutex);
    if (!counted_) return;
    counted_ = false;
    if (listed_) s_.heading.erase(in_heading_), listed_ = false;
    if (--s_.per_peer[peer_] <= 0) s_.per_peer.erase(peer_);
    --s_.open_connections;
  }
  void counted() { counted_ = true; }

 private:
  static constexpr std::uint32_t kHeadBytes = 16 * 1024;
  static std::chrono::steady_clock::duration seconds(double s) {
    return std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(s));
  }

  void head_done() {
    const std::lock_guard<std::mutex> lock(s_.connections_mutex);
    if (listed_) s_.heading.erase(in_heading_), listed_ = false;
  }

  void on_head(beast::error_code ec) {
    head_done();
    if (ec == http::error::header_limit) return write(error(431, fmt::format("the request's head is over {} bytes", kHeadBytes)));
    if (ec.category() == http::make_error_code(http::error::bad_target).category() && ec != http::error::end_of_stream &&
        ec != http::error::partial_message)
      return write(error(400, "malformed request"));
    if (ec) return close();  // gone, or too slow (the stream closed itself at the deadline)
    request_ = request_of(*parser_);
    if (websocket::is_upgrade(parser_->get())) return upgrade();
    if (auto refused = s_.before_body(request_, body_limit_)) return write(std::move(*refused));
    if (parser_->is_done()) return dispatch();
    parser_->body_limit(body_limit_);
    stream_.expires_after(seconds(s_.o.body_timeout_s));
    const auto read_body = [self = shared_from_this()] {
      http::async_read(self->stream_, self->buffer_, *self->parser_,
                       [self](beast::error_code e, std::size_t) { self->on_body(e); });
    };
    // A client that waits for leave to send its body (curl does, for large ones) gets it.
    if (beast::iequals(request_.header("Expect"), "100-continue")) {
      static const std::string kContinue = "HTTP/1.1 100 Continue\r\n\r\n";
      asio::async_write(stream_, asio::buffer(kContinue), [read_body](beast::error_code e, std::size_t) {
        if (!e) read_body();
      });
      return;
    }
    read_body();
  }

  void on_body(beast::error_code ec) {
    if (ec == http::error::body_limit) return write(error(413, fmt::format("the body is larger than {} bytes", body_limit_)));
    if (ec) return close();  // gone, or too slow (the stream closed itself at the deadline)
    request_.body = std::move(parser_->get().body());
    parser_.reset();
    dispatch();
  }

  // The request on its lane: the E-stop and the status on threads of their own, the rest on the
  // workers.
  void dispatch() {
    stream_.expires_never();
    const bool post = request_.method == "POST", get = request_.method == "GET";
    asio::thread_pool& lane = post && request_.path == "/api/estop"  ? s_.estop_lane
                              : get && request_.path == "/api/status" ? s_.status_lane
                                                                      : s_.workers;
    asio::post(lane, [self = shared_from_this()] {
      Reply r;
      try {
        r = self->s_.after_body(self->request_);
      } catch (const std::exception& e) {
        r = error(500, fmt::format("internal error: {}", excerpt(e.what(), 200)));
      }
      // A large body (a program's text, or junk up to the route's limit) was held in memory the
      // allocator keeps for the thread that read it: give it back to the system, so that
      // requests cannot pin the server's memory one after another.
      if (self->request_.body.size() > kTrimAfterBodyBytes) {
        std::string().swap(self->request_.body);
        ::malloc_trim(0);
      }
      self->answer(std::move(r));
    });
  }

  void write(Reply r) {
    out_ = bytes_of(r, request_.method == "HEAD");
    stream_.expires_after(seconds(kWriteTimeout_s));
    asio::async_write(stream_, asio::buffer(out_), [self = shared_from_this()](beast::error_code ec, std::size_t) {
      if (ec) return self->close();
      self->linger();
    });
  }

  // The answer is sent: say so (FIN), then read and drop what the client still sends (a body
  // refused unread) until it closes, for at most kLinger_s, so that a reset cannot overtake
  // the answer.
  void linger() {
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
    stream_.expires_after(seconds(kLinger_s));
    drain();
  }
  void drain() {
    scratch_.resize(16384);
    stream_.async_read_some(asio::buffer(scratch_), [self = shared_from_this()](beast::error_code ec, std::size_t n) {
      self->drained_ += n;
      if (ec || self->drained_ > kLingerBytes) return self->close();
      self->drain();
    });
  }

  void close() {
    release();
    beast::error_code ignored;
    stream_.socket().close(ignored);
  }

  void upgrade();

  static constexpr double kWriteTimeout_s = 30, kLinger_s = 2;
  static constexpr std::size_t kLingerBytes = 64 << 20;
  static constexpr std::size_t kTrimAfterBodyBytes = 1 << 20;

  Server::Impl& s_;
  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  Request request_;
  std::string out_, scratch_;
  std::size_t drained_ = 0, body_limit_ = 0;
  std::string peer_;
  bool counted_ = false, listed_ = false;
  std::list<std::weak_ptr<Connection>>::iterator in_heading_;
};

// A live-stream viewer: the WebSocket, a mailbox of one frame (a frame that arrives while one
// is being written replaces the waiting one, counted as skipped), everything on the I/O thread.
class Viewer : public std::enable_shared_from_this<Viewer> {
 public:
  Viewer(Server::Impl& s, beast::tcp_stream&& stream) : s_(s), ws_(std::move(stream)) {}
  std::atomic<std::uint64_t> sent{0}, skipped{0};

  void start(const http::request<http::string_body>& upgrade_request) {
    websocket::stream_base::timeout t{};
    t.handshake_timeout = std::chrono::seconds(10);
    t.idle_timeout = std::chrono::seconds(60);  // a ping at 30 s: a viewer that answers none is gone
    t.keep_alive_pings = true;
    ws_.set_option(t);
    ws_.read_message_max(4096);
    ws_.async_accept(upgrade_request, [self = shared_from_this()](beast::error_code ec) {
      if (ec) return self->close();
      self->read();
    });
  }

  // A new frame (I/O thread).
  void offer(std::shared_ptr<const std::string> frame) {
    if (closed_) return;
    if (writing_) {
      if (waiting_) ++skipped;
      waiting_ = std::move(frame);
      return;
    }
    write(std::move(frame));
  }

  void close() {
    if (closed_) return;
    closed_ = true;
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().close(ignored);
    std::shared_ptr<Viewer> self;
    {
      const std::lock_guard<std::mutex> lock(s_.viewers_mutex);
      const auto it = std::find(s_.viewers.begin(), s_.viewers.end(), shared_from_this());
      if (it == s_.viewers.end()) return;
      self = std::move(*it);
      s_.viewers.erase(it);
    }
    s_.skipped_gone += skipped.load();
    s_.sent_gone += sent.load();
  }

 private:
  void write(std::shared_ptr<const std::string> frame) {
    writing_ = std::move(frame);
    ws_.text(true);
    ws_.async_write(asio::buffer(*writing_), [self = shared_from_this()](beast::error_code ec, std::size_t) {
      self->writing_.reset();
      if (ec) return self->close();
      ++self->sent;
      if (self->waiting_) self->write(std::exchange(self->waiting_, nullptr));
    });
  }
  // What viewers send is read (pongs and the close handshake are handled by the stream) and
  // dropped.
  void read() {
    ws_.async_read(in_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
      if (ec) return self->close();
      self->in_.consume(self->in_.size());
      self->read();
    });
  }

  Server::Impl& s_;
  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer in_;
  std::shared_ptr<const std::string> writing_, waiting_;
  bool closed_ = false;
};

void Connection::upgrade() {
  if (request_.path != "/api/live") return write(error(404, "no WebSocket here: the live stream is /api/live"));
  if (auto refused = s_.ws_refusal(request_)) return write(std::move(*refused));
  release();  // a viewer is counted by max_viewers
  stream_.expires_never();
  auto v = std::make_shared<Viewer>(s_, std::move(stream_));
  {
    const std::lock_guard<std::mutex> lock(s_.viewers_mutex);
    s_.viewers.push_back(v);
  }
  v->start(parser_->get());
}

}  // namespace

// The Host header names this server: any port of a loopback name when bound to loopback.
bool Server::Impl::host_allowed(const Request& q) const {
  if (o.allow_remote) return true;
  std::string host = q.header("Host");
  if (host.empty()) return true;  // HTTP/1.0 clients
  if (host.front() == '[') host = host.substr(0, host.find(']') + 1);
  else host = host.substr(0, host.find(':'));
  // Host names are case-insensitive (RFC 9110): LOCALHOST is localhost.
  using text_scan::iequals;
  return host == "127.0.0.1" || iequals(host, "localhost") || host == "[::1]" || iequals(host, o.bind);
}

std::optional<Reply> Server::Impl::authorize(const Request& q, bool& by_cookie) {
  if (!same_token(request_token(q, by_cookie), token)) return Reply{401, "", "text/plain", "WWW-Authenticate: Bearer\r\n"};
  if (by_cookie && q.method != "GET") {
    // A browser's request on the cookie: only from this server's own page.
    if (q.header("Origin") != "http://" + q.header("Host")) return error(403, "cross-origin request refused");
    if (q.header("Content-Type").rfind("application/json", 0) != 0)
      return error(415, "send JSON with Content-Type: application/json");
  }
  return std::nullopt;
}

bool Server::Impl::holds_control(const Request& q) {
  const std::string id = q.header("X-Machplan-Client");
  const std::lock_guard<std::mutex> lock(control_mutex);
  return !controller.empty() && id == controller;
}

// What the head alone decides, on the I/O thread before any byte of the body is read: the
// Host, the page's files, the token, control, and the body's size (`body_limit` for the rest).
std::optional<Reply> Server::Impl::before_body(const Request& q, std::size_t& body_limit) {
  if (!host_allowed(q)) return error(403, "this server answers to its loopback address only (Host refused)");
  if (q.path.rfind("/api/", 0) != 0 && q.path != "/api") {
    if (q.method != "GET" && q.method != "HEAD") return error(405, "the page's files are read with GET");
    return serve_file(q);
  }
  bool by_cookie = false;
  if (auto refused = authorize(q, by_cookie)) return refused;
  // A command from a client not in control is refused before its body is read or parsed.
  if (q.method == "POST") {
    const ApiRoute* r = find_api_route(q.path.substr(4));
    if (r && r->post && r->post_needs_control && !holds_control(q)) return error(409, kTakeControlFirst);
  }
  body_limit = q.path == "/api/job" ? o.max_job_bytes : o.max_body_bytes;
  if (q.content_length && *q.content_length > body_limit)
    return error(413, fmt::format("the body is larger than {} bytes", body_limit));
  return std::nullopt;
}

// The rest, on the request's lane once the body is in: the body's JSON, then the route.
Reply Server::Impl::after_body(const Request& q) {
  json body = json::object();
  if (!q.body.empty()) {
    if (json_nested_deeper_than(q.body, kMaxJsonDepth))
      return error(400, fmt::format("the body nests arrays or objects deeper than {} levels", kMaxJsonDepth));
    body = json::parse(q.body, nullptr, false);
    if (body.is_discarded()) return error(400, "the body is not valid JSON");
    if (!body.is_object()) return error(400, "the body must be a JSON object");
  }
  try {
    return api(q, q.path.substr(4), body);
  } catch (const Busy& e) {
    return error(409, e.what());
  } catch (const Cancelled& e) {
    return error(409, fmt::format("cancelled: {}", e.what()));
  } catch (const InputError& e) {
    return error(400, panel.clean(e.what()));
  } catch (const OutputError& e) {
    // The server's disk refused a file (an upload stored for a job): not the request's fault.
    return error(507, panel.clean(e.what()));
  } catch (const Infeasible& e) {
    // A refusal the request's origin can lift names the page's fields for it.
    if (e.option() == "origin_mm") return error(422, panel.clean(Infeasible(e.message(), "the origin X, Y fields").what()));
    return error(422, panel.clean(e.what()));
  } catch (const json::exception& e) {
    return error(400, fmt::format("wrong type in the request: {}", excerpt(e.what(), 200)));
  }
}

Reply Server::Impl::api(const Request& q, const std::string& path, const json& body) {
  const std::string& method = q.method;
  const auto need = [&](const char* m) {
    if (method != m) throw InputError::field("method", fmt::format("{} takes {}", path, m));
  };
  const bool get = method == "GET";
  const ApiRoute* route_it = find_api_route(path);
  if (!route_it) return error(404, fmt::format("no route /api{}", excerpt(path, 80)));
  if (!(get ? route_it->get : method == "POST" && route_it->post))
    return error(405, fmt::format("/api{} does not take {}", path, excerpt(method, 10)));

  // Open to every authenticated client.
  if (path == "/status") {
    json s = panel.status();
    const std::string id = q.header("X-Machplan-Client");
    const std::lock_guard<std::mutex> lock(control_mutex);
    s["control"] = {{"held", !controller.empty()}, {"yours", !controller.empty() && id == controller}};
    return ok(s);
  }
  if (path == "/login")
    return {200, "{\"ok\":true}\n", "application/json",
            fmt::format("Set-Cookie: machplan_token={}; Path=/; HttpOnly; SameSite=Strict\r\n", token)};
  if (path == "/estop") {
    panel.estop();
    return ok({{"ok", true}, {"estop", true}});
  }
  if (get && path == "/job") {
    const auto d = panel.job_drawing();
    return d ? Reply{200, *d} : error(404, "no job is loaded");
  }
  if (get && path == "/report") {
    const auto r = panel.report();
    return r ? Reply{200, *r} : error(404, "no run has ended yet");
  }
  if (get && path == "/guard") {
    const auto g = panel.guard_drawing();
    return g ? Reply{200, *g} : error(404, "no guard session has started");
  }
  if (get && path == "/history") return ok(panel.history());
  if (path == "/control") {
    const std::string id = q.header("X-Machplan-Client");
    if (id.size() < 8 || id.size() > 64 ||
        !std::all_of(id.begin(), id.end(), [](char ch) { return std::isalnum(static_cast<unsigned char>(ch)) || ch == '-'; }))
      return error(400, "name the client with X-Machplan-Client: 8 to 64 letters, digits or '-'");
    const bool take = !body.contains("take") || body.at("take").get<bool>();
    const std::lock_guard<std::mutex> lock(control_mutex);
    if (take) controller = id;
    else if (controller == id) controller.clear();
    return ok({{"control", {{"held", !controller.empty()}, {"yours", controller == id}}}});
  }

  // The rest changes the machine: the client must hold control.
  if (!holds_control(q)) return error(409, kTakeControlFirst);
  if (path == "/job") {
    JobRequest r;
    r.program = body.at("program").get<std::string>();
    if (body.contains("name")) r.name = body.at("name").get<std::string>();
    if (body.contains("origin") && !body.at("origin").is_null()) {
      const json& o = body.at("origin");
      if (!o.is_array() || o.size() != 2 || !o[0].is_number() || !o[1].is_number())
        throw InputError::field("origin", "must be [x, y] in mm");
      r.origin_mm = Eigen::Vector2d(o[0].get<double>(), o[1].get<double>());
    }
    if (body.contains("materials") && !body.at("materials").is_null()) r.materials = body.at("materials").get<std::string>();
    r.material = whole_number(body, "material", 0, 999999, "material number").value_or(-1);
    return ok(panel.load_job(r));
  }
  if (path == "/run") {
    panel.run(whole_number(body, "from_line", 1, 10000000, "line number"));
    return ok({{"ok", true}});
  }
  if (path == "/hold") return panel.hold(), ok({{"ok", true}});
  if (path == "/resume") return panel.resume(), ok({{"ok", true}});
  if (path == "/stop") return panel.stop(), ok({{"ok", true}});
  if (path == "/reset") return panel.reset(), ok({{"ok", true}});
  if (path == "/override") {
    panel.set_overrides(number(body, "feed"), number(body, "rapid"));
    return ok({{"ok", true}});
  }
  if (path == "/recover") {
    const std::optional<double> mm = number(body, "mm");
    if (!mm) throw InputError::field("mm", "takes {\"mm\": N}: millimetres along the cut's path (negative: back)");
    panel.recover(*mm);
    return ok({{"ok", true}});
  }
  if (path == "/thc") {
    const auto it = body.find("enabled");
    if (it == body.end() || !it->is_boolean()) throw InputError::field("enabled", "takes {\"enabled\": true|false}");
    panel.set_thc(it->get<bool>());
    return ok({{"ok", true}});
  }
  if (path == "/jog") {
    panel.jog(number(body, "x").value_or(0.0), number(body, "y").value_or(0.0));
    return ok({{"ok", true}});
  }
  if (path == "/guard") {
    GuardRequest g;
    g.profile = body.at("profile").get<std::string>();
    guard::GuardRunOptions& go = g.options;
    go.machine = body.value("machine", std::string("xy_table"));
    go.region.side = parse_machining_side(body.at("side").get<std::string>()).value;
    go.region.tool_radius_mm = body.at("tool_radius_mm").get<double>();
    go.guard.tolerance_mm = body.at("tolerance_mm").get<double>();
    if (body.contains("strategy")) go.guard.strategy = executor::parse_guard_strategy(body.at("strategy").get<std::string>()).value;
    if (body.contains("feed_mm_per_s")) go.feed_mm_per_s = body.at("feed_mm_per_s").get<double>();
    go.finish = body.value("finish", true);
    panel.start_guard(std::move(g));
    return ok({{"ok", true}});
  }
  need("POST");
  return error(404, "no route");
}

Reply Server::Impl::serve_file(const Request& q) const {
  const std::string name = q.path == "/" ? "index.html" : q.path.substr(1);
  const auto f = files.find(name);
  if (f == files.end()) return error(404, "no such page");
  static const std::map<std::string, std::string> kTypes = {
      {".html", "text/html; charset=utf-8"}, {".css", "text/css; charset=utf-8"}, {".js", "text/javascript; charset=utf-8"},
      {".svg", "image/svg+xml"},             {".txt", "text/plain; charset=utf-8"}};
  const std::string ext = name.substr(name.rfind('.'));
  const auto t = kTypes.find(ext);
  Reply r{200, f->second, t == kTypes.end() ? "application/octet-stream" : t->second};
  r.headers = fmt::format("Content-Security-Policy: default-src 'self'; connect-src 'self' ws://{}; img-src 'self' data:; "
                          "frame-ancestors 'none'; base-uri 'none'; form-action 'none'\r\n",
                          q.header("Host"));
  return r;
}

std::optional<Reply> Server::Impl::ws_refusal(const Request& q) {
  if (!host_allowed(q)) return error(403, "Host refused");
  bool by_cookie = false;
  if (!same_token(request_token(q, by_cookie), token)) return Reply{401, "", "text/plain", "WWW-Authenticate: Bearer\r\n"};
  const std::string origin = q.header("Origin");
  if (!origin.empty() && origin != "http://" + q.header("Host")) return error(403, "cross-origin WebSocket refused");
  const std::lock_guard<std::mutex> lock(viewers_mutex);
  if (static_cast<int>(viewers.size()) >= o.max_viewers) return error(503, fmt::format("at most {} viewers at once", o.max_viewers));
  return std::nullopt;
}

// ---- connections -------------------------------------------------------------------------------

void Server::Impl::listen() {
  beast::error_code ec;
  tcp::resolver resolver(ioc);
  const auto found = resolver.resolve(o.bind, std::to_string(o.port), tcp::resolver::passive | tcp::resolver::numeric_service, ec);
  const auto cannot = [&] {
    return InputError::field("port", fmt::format("cannot listen on {}:{} (in use, or not an address of this machine)", o.bind, o.port));
  };
  if (ec || found.empty()) throw cannot();
  const tcp::endpoint at = found.begin()->endpoint();
  acceptor.open(at.protocol(), ec);
  if (!ec) acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(at, ec);
  if (!ec) acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) throw cannot();
  port = acceptor.local_endpoint().port();
  // Every connection is a file descriptor: as many as the limits allow, within the process's.
  rlimit files{};
  if (getrlimit(RLIMIT_NOFILE, &files) == 0) {
    const rlim_t want = static_cast<rlim_t>(o.max_connections) + 256;
    if (files.rlim_cur < want) {
      files.rlim_cur = std::min(want, files.rlim_max);
      setrlimit(RLIMIT_NOFILE, &files);
      getrlimit(RLIMIT_NOFILE, &files);
    }
    if (files.rlim_cur < want) o.max_connections = std::max(16, static_cast<int>(files.rlim_cur) - 256);
    o.max_connections_per_peer = std::min(o.max_connections_per_peer, o.max_connections);
  }
}

void Server::Impl::accept() {
  acceptor.async_accept([this](beast::error_code ec, tcp::socket socket) {
    if (!acceptor.is_open()) return;
    if (!ec) {
      admit(std::move(socket));
      return accept();
    }
    // Out of file descriptors (or another passing failure): try again shortly, not in a loop.
    accept_pause.expires_after(std::chrono::milliseconds(50));
    accept_pause.async_wait([this](beast::error_code e) {
      if (!e) accept();
    });
  });
}

// A new connection within the limits: a peer at max_connections_per_peer (or the server at
// max_connections) makes room by closing its oldest connection still sending its head; with
// none to close the new one is refused.
void Server::Impl::admit(tcp::socket socket) {
  beast::error_code ec;
  const tcp::endpoint from = socket.remote_endpoint(ec);
  if (ec) return;
  const std::string peer = from.address().to_string();
  std::shared_ptr<Connection> victim;
  std::shared_ptr<Connection> c;
  {
    const std::lock_guard<std::mutex> lock(connections_mutex);
    const bool peer_full = per_peer[peer] >= o.max_connections_per_peer, all_full = open_connections >= o.max_connections;
    if (peer_full || all_full) {
      for (const auto& w : heading) {
        auto h = w.lock();
        if (h && (!peer_full || h->peer() == peer)) {
          victim = std::move(h);
          break;
        }
      }
      if (!victim) {
        if (per_peer[peer] == 0) per_peer.erase(peer);
        ++refused;
        return;  // the socket closes here
      }
    }
    c = std::make_shared<Connection>(*this, std::move(socket), peer);
    ++per_peer[peer];
    ++open_connections;
    c->counted();
    c->enlist(heading.insert(heading.end(), c));
  }
  if (victim) {
    victim->evict();
    ++evicted;
  }
  c->start();
}

// ---- the live stream ---------------------------------------------------------------------------

void Server::Impl::stream() {
  using Clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / o.frame_hz));
  auto next = Clock::now();
  while (streaming.load()) {
    next += period;
    panel.service();
    const auto frame = std::make_shared<const std::string>(panel.live_frame());
    ++frames;
    {
      const std::lock_guard<std::mutex> lock(viewers_mutex);
      for (const auto& v : viewers) asio::post(ioc, [v, frame] { v->offer(frame); });
    }
    std::this_thread::sleep_until(next);
    if (Clock::now() - next > std::chrono::seconds(1)) next = Clock::now();  // fell far behind: no burst
  }
}

// ---- Server -----------------------------------------------------------------------------------

Server::Server(Panel& panel, ServerOptions options) : impl_(std::make_unique<Impl>(panel, std::move(options))) {
  Impl& m = *impl_;
  m.o.validate();
  if (!m.o.allow_remote && !is_loopback(m.o.bind))
    throw InputError::field("bind", fmt::format("'{}' is not a loopback address: binding it needs allow_remote (serve: --allow-remote)", excerpt(m.o.bind)));
  m.token = m.o.token.empty() ? random_token() : m.o.token;
  const std::string root = m.o.web_root.empty() ? web_root_folder() : m.o.web_root;
  if (root.empty()) throw InputError::field("web_root", "the panel's page (share/machplan/panel) was not found");
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(root, ec)) {
    if (!e.is_regular_file()) continue;
    std::ifstream in(e.path(), std::ios::binary);
    m.files[e.path().filename().string()] = std::string(std::istreambuf_iterator<char>(in), {});
  }
  if (!m.files.count("index.html")) throw InputError(root, 0, "no index.html: the panel's page is incomplete");
  m.listen();
  m.accept();
  m.io_thread = std::thread([&m] { m.ioc.run(); });
  m.streamer = std::thread([&m] { m.stream(); });
}

Server::~Server() {
  Impl& m = *impl_;
  m.streaming = false;
  if (m.streamer.joinable()) m.streamer.join();
  // Stop accepting and close every viewer on the I/O thread, then stop it: the handlers left
  // (and the connections they hold) go with the io_context.
  asio::post(m.ioc, [&m] {
    beast::error_code ignored;
    m.acceptor.close(ignored);
    m.accept_pause.cancel();
    std::list<std::shared_ptr<Viewer>> viewers;
    {
      const std::lock_guard<std::mutex> lock(m.viewers_mutex);
      viewers = m.viewers;
    }
    for (const auto& v : viewers) v->close();
    m.ioc.stop();
  });
  if (m.io_thread.joinable()) m.io_thread.join();
  // Requests under way finish (their answers go nowhere).
  m.workers.join();
  m.estop_lane.join();
  m.status_lane.join();
}

int Server::port() const { return impl_->port; }
const std::string& Server::token() const { return impl_->token; }
std::string Server::url() const { return fmt::format("http://{}:{}/?token={}", impl_->o.bind, impl_->port, impl_->token); }

Server::Counters Server::counters() const {
  Counters c;
  c.frames = impl_->frames.load();
  c.skipped = impl_->skipped_gone.load();
  c.sent = impl_->sent_gone.load();
  c.evicted = impl_->evicted.load();
  c.refused = impl_->refused.load();
  const std::lock_guard<std::mutex> lock(impl_->viewers_mutex);
  for (const auto& v : impl_->viewers) c.skipped += v->skipped.load(), c.sent += v->sent.load();
  c.viewers = static_cast<int>(impl_->viewers.size());
  return c;
}

}  // namespace machplan::panel
