// The panel server's transport: the listening socket, each connection from its accept to its
// close, the WebSocket viewers and the live stream. The routes are in routes.cpp.
#include "cli/panel/server.h"

#include <malloc.h>
#include <sys/random.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <limits>
#include <list>
#include <mutex>
#include <optional>
#include <thread>

#include <boost/beast/websocket.hpp>
#include <fmt/format.h>

#include "cli/panel/server_impl.h"
#include "engine/common/error.h"

namespace machplan::panel {

namespace fs = std::filesystem;
namespace websocket = beast::websocket;

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

}  // namespace

// One client connection, from its accept to its close, on the I/O thread: the head within
// head_timeout_s, the checks that need only the head, the body within body_timeout_s, the
// request on its lane, the answer, then a lingering close (the client reads the whole answer
// even when its body was refused unread). A WebSocket upgrade of /api/live becomes a Viewer.
class Connection : public std::enable_shared_from_this<Connection> {
 public:
  Connection(Server::Impl& s, tcp::socket socket, std::string peer) : s_(s), stream_(std::move(socket)), peer_(std::move(peer)) {}
  ~Connection() { release(); }

  // Counted for its peer and listed as sending its head at `at` (admit, connections_mutex held):
  // release() undoes both.
  void enlist(std::list<std::weak_ptr<Connection>>::iterator at) {
    counted_ = listed_ = true;
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
      self->accepted_ = true;
      self->read();
      if (self->waiting_) self->write(std::exchange(self->waiting_, nullptr));
    });
  }

  // A new frame (I/O thread). Until the handshake is done it waits in the mailbox: a frame
  // written before it would go out as a client's (masked), which browsers refuse.
  void offer(std::shared_ptr<const std::string> frame) {
    if (closed_) return;
    if (writing_ || !accepted_) {
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
  bool accepted_ = false, closed_ = false;
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
    const auto held = per_peer.find(peer);
    const bool peer_full = held != per_peer.end() && held->second >= o.max_connections_per_peer;
    const bool all_full = open_connections >= o.max_connections;
    if (peer_full || all_full) {
      for (const auto& w : heading) {
        auto h = w.lock();
        if (h && (!peer_full || h->peer() == peer)) {
          victim = std::move(h);
          break;
        }
      }
      if (!victim) {
        ++refused;
        return;  // the socket closes here
      }
    }
    c = std::make_shared<Connection>(*this, std::move(socket), peer);
    ++per_peer[peer];
    ++open_connections;
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
