#include "cli/panel/server.h"

#include <malloc.h>
#include <sys/random.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <list>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include <civetweb.h>
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
using nlohmann::json;

void ServerOptions::validate() const {
  require_field(port >= 0 && port <= 65535, "port", port, "must be in 0 .. 65535");
  require_field(!bind.empty() && bind.find_first_of(",: \t") == std::string::npos, "bind", fmt::format("'{}'", excerpt(bind)),
                "is not an IPv4 address or host name");
  require_field(std::isfinite(frame_hz) && frame_hz >= 30 && frame_hz <= 200, "frame_hz", frame_hz, "must be in 30 .. 200");
  require_field(max_viewers >= 1 && max_viewers <= 1000, "max_viewers", max_viewers, "must be in 1 .. 1000");
  require_field(threads >= max_viewers + 8 && threads <= 2000, "threads", threads, "must be max_viewers + 8 .. 2000");
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

std::string header(const mg_connection* c, const char* name) {
  const char* v = mg_get_header(c, name);
  return v ? std::string(v) : std::string();
}

// The token of a request: the bearer header, else the login cookie. `by_cookie` says which.
std::string request_token(const mg_connection* c, bool& by_cookie) {
  by_cookie = false;
  const std::string auth = header(c, "Authorization");
  if (auth.size() > 7 && strncasecmp(auth.c_str(), "Bearer ", 7) == 0) return auth.substr(7);
  const std::string cookies = header(c, "Cookie");
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
    case 422: return "Unprocessable Content";
    case 500: return "Internal Server Error";
    case 503: return "Service Unavailable";
    case 507: return "Insufficient Storage";
  }
  return "Status";
}

int send(mg_connection* c, const Reply& r) {
  const std::string head = fmt::format(
      "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n"
      "X-Content-Type-Options: nosniff\r\nX-Frame-Options: DENY\r\nReferrer-Policy: no-referrer\r\nConnection: close\r\n{}\r\n",
      r.code, reason(r.code), r.type, r.body.size(), r.headers);
  mg_write(c, head.data(), head.size());
  if (!r.body.empty()) mg_write(c, r.body.data(), r.body.size());
  return r.code;
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

struct Viewer {
  mg_connection* conn = nullptr;
  std::mutex m;
  std::condition_variable cv;
  std::shared_ptr<const std::string> next;
  bool closing = false;
  std::thread writer;
  std::atomic<std::uint64_t> sent{0}, skipped{0};
};

}  // namespace

struct Server::Impl {
  Panel& panel;
  ServerOptions o;
  std::string token;
  mg_context* ctx = nullptr;
  int port = 0;
  std::map<std::string, std::string> files;  // the page: name -> bytes

  std::mutex control_mutex;
  std::string controller;  // the client that holds control ("" : nobody)

  std::mutex viewers_mutex;
  std::list<std::unique_ptr<Viewer>> viewers;
  std::atomic<std::uint64_t> frames{0}, skipped_gone{0}, sent_gone{0};
  std::atomic<bool> streaming{true};
  std::thread streamer;

  Impl(Panel& p, ServerOptions opt) : panel(p), o(std::move(opt)) {}

  bool host_allowed(const mg_connection* c) const;
  int handle(mg_connection* c);
  Reply route(mg_connection* c, const std::string& method, const std::string& uri);
  Reply api(mg_connection* c, const std::string& method, const std::string& path, const json& body);
  Reply serve_file(mg_connection* c, const std::string& uri) const;
  std::optional<Reply> authorize(mg_connection* c, const std::string& method, bool& by_cookie);
  bool holds_control(const mg_connection* c);
  void stream();
  int ws_connect(mg_connection* c);
  void ws_ready(mg_connection* c);
  void ws_close(const mg_connection* c);
};

// The Host header names this server: any port of a loopback name when bound to loopback.
bool Server::Impl::host_allowed(const mg_connection* c) const {
  if (o.allow_remote) return true;
  std::string host = header(c, "Host");
  if (host.empty()) return true;  // HTTP/1.0 clients
  if (host.front() == '[') host = host.substr(0, host.find(']') + 1);
  else host = host.substr(0, host.find(':'));
  // Host names are case-insensitive (RFC 9110): LOCALHOST is localhost.
  using text_scan::iequals;
  return host == "127.0.0.1" || iequals(host, "localhost") || host == "[::1]" || iequals(host, o.bind);
}

std::optional<Reply> Server::Impl::authorize(mg_connection* c, const std::string& method, bool& by_cookie) {
  if (!same_token(request_token(c, by_cookie), token)) return Reply{401, "", "text/plain", "WWW-Authenticate: Bearer\r\n"};
  if (by_cookie && method != "GET") {
    // A browser's request on the cookie: only from this server's own page.
    const std::string origin = header(c, "Origin"), host = header(c, "Host");
    if (origin != "http://" + host) return error(403, "cross-origin request refused");
    if (header(c, "Content-Type").rfind("application/json", 0) != 0)
      return error(415, "send JSON with Content-Type: application/json");
  }
  return std::nullopt;
}

bool Server::Impl::holds_control(const mg_connection* c) {
  const std::string id = header(c, "X-Machplan-Client");
  const std::lock_guard<std::mutex> lock(control_mutex);
  return !controller.empty() && id == controller;
}

// Bodies larger than this are followed by malloc_trim() (Server::Impl::handle).
constexpr long long kTrimAfterBodyBytes = 1 << 20;

int Server::Impl::handle(mg_connection* c) {
  const mg_request_info* ri = mg_get_request_info(c);
  const std::string method = ri->request_method ? ri->request_method : "";
  const std::string uri = ri->local_uri ? ri->local_uri : "";
  // civetweb's workers have small stacks (about 100 kB): the request is handled on a thread of
  // ours (planning a job and building a guard region go deep), this worker waits for it.
  Reply r = std::async(std::launch::async, [&]() -> Reply {
              try {
                return route(c, method, uri);
              } catch (const std::exception& e) {
                return error(500, fmt::format("internal error: {}", excerpt(e.what(), 200)));
              }
            }).get();
  // A large body (a program's text, or junk up to the route's limit) was held in memory the
  // allocator keeps for the thread that read it: give it back to the system, so that requests
  // cannot pin the server's memory one after another.
  if (ri->content_length > kTrimAfterBodyBytes) ::malloc_trim(0);
  return send(c, r);
}

namespace {

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

}  // namespace

Reply Server::Impl::route(mg_connection* c, const std::string& method, const std::string& uri) {
  if (!host_allowed(c)) return error(403, "this server answers to its loopback address only (Host refused)");
  if (uri.rfind("/api/", 0) != 0 && uri != "/api") {
    if (method != "GET" && method != "HEAD") return error(405, "the page's files are read with GET");
    return serve_file(c, uri);
  }
  bool by_cookie = false;
  if (auto refused = authorize(c, method, by_cookie)) return *refused;
  // A command from a client not in control is refused before its body is read or parsed.
  if (method == "POST") {
    const ApiRoute* r = find_api_route(uri.substr(4));
    if (r && r->post && r->post_needs_control && !holds_control(c))
      return error(409, kTakeControlFirst);
  }
  // The body: JSON, bounded before it is read.
  const mg_request_info* ri = mg_get_request_info(c);
  const std::size_t limit = uri == "/api/job" ? o.max_job_bytes : o.max_body_bytes;
  if (ri->content_length > 0 && static_cast<unsigned long long>(ri->content_length) > limit)
    return error(413, fmt::format("the body is larger than {} bytes", limit));
  std::string raw;
  if (method == "POST") {
    // One allocation of the announced size, not a doubling series of them.
    if (ri->content_length > 0) raw.reserve(static_cast<std::size_t>(ri->content_length));
    std::string buf(16384, '\0');
    for (int n; (n = mg_read(c, buf.data(), buf.size())) > 0;) {
      raw.append(buf.data(), static_cast<std::size_t>(n));
      if (raw.size() > limit) return error(413, fmt::format("the body is larger than {} bytes", limit));
    }
  }
  json body = json::object();
  if (!raw.empty()) {
    if (json_nested_deeper_than(raw, kMaxJsonDepth))
      return error(400, fmt::format("the body nests arrays or objects deeper than {} levels", kMaxJsonDepth));
    body = json::parse(raw, nullptr, false);
    if (body.is_discarded()) return error(400, "the body is not valid JSON");
    if (!body.is_object()) return error(400, "the body must be a JSON object");
  }
  try {
    return api(c, method, uri.substr(4), body);
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

Reply Server::Impl::api(mg_connection* c, const std::string& method, const std::string& path, const json& body) {
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
    const std::string id = header(c, "X-Machplan-Client");
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
    const std::string id = header(c, "X-Machplan-Client");
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
  if (!holds_control(c)) return error(409, kTakeControlFirst);
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

Reply Server::Impl::serve_file(mg_connection* c, const std::string& uri) const {
  const std::string name = uri == "/" ? "index.html" : uri.substr(1);
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
                          header(c, "Host"));
  return r;
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
      for (const auto& v : viewers) {
        {
          const std::lock_guard<std::mutex> vl(v->m);
          if (v->next) ++v->skipped;  // the viewer has not taken the last one: it is dropped
          v->next = frame;
        }
        v->cv.notify_one();
      }
    }
    std::this_thread::sleep_until(next);
    if (Clock::now() - next > std::chrono::seconds(1)) next = Clock::now();  // fell far behind: no burst
  }
}

int Server::Impl::ws_connect(mg_connection* c) {
  bool by_cookie = false;
  Reply refused;
  bool refuse = false;
  if (!host_allowed(c)) {
    refused = error(403, "Host refused");
    refuse = true;
  } else if (!same_token(request_token(c, by_cookie), token)) {
    refused = Reply{401, "", "text/plain", "WWW-Authenticate: Bearer\r\n"};
    refuse = true;
  } else {
    const std::string origin = header(c, "Origin");
    if (!origin.empty() && origin != "http://" + header(c, "Host")) {
      refused = error(403, "cross-origin WebSocket refused");
      refuse = true;
    }
  }
  if (!refuse) {
    const std::lock_guard<std::mutex> lock(viewers_mutex);
    if (static_cast<int>(viewers.size()) >= o.max_viewers) {
      refused = error(503, fmt::format("at most {} viewers at once", o.max_viewers));
      refuse = true;
    }
  }
  if (refuse) {
    send(c, refused);
    return 1;
  }
  return 0;
}

void Server::Impl::ws_ready(mg_connection* c) {
  auto v = std::make_unique<Viewer>();
  v->conn = c;
  Viewer* raw = v.get();
  mg_set_user_connection_data(c, raw);
  raw->writer = std::thread([raw] {
    for (;;) {
      std::shared_ptr<const std::string> f;
      {
        std::unique_lock<std::mutex> lock(raw->m);
        raw->cv.wait(lock, [&] { return raw->closing || raw->next; });
        if (raw->closing) return;
        f = std::move(raw->next);
        raw->next.reset();
      }
      if (mg_websocket_write(raw->conn, MG_WEBSOCKET_OPCODE_TEXT, f->data(), f->size()) <= 0) return;
      ++raw->sent;
    }
  });
  const std::lock_guard<std::mutex> lock(viewers_mutex);
  viewers.push_back(std::move(v));
}

void Server::Impl::ws_close(const mg_connection* c) {
  auto* raw = static_cast<Viewer*>(mg_get_user_connection_data(c));
  if (!raw) return;
  std::unique_ptr<Viewer> gone;
  {
    const std::lock_guard<std::mutex> lock(viewers_mutex);
    for (auto it = viewers.begin(); it != viewers.end(); ++it) {
      if (it->get() != raw) continue;
      gone = std::move(*it);
      viewers.erase(it);
      break;
    }
  }
  if (!gone) return;
  {
    const std::lock_guard<std::mutex> lock(gone->m);
    gone->closing = true;
  }
  gone->cv.notify_one();
  if (gone->writer.joinable()) gone->writer.join();
  skipped_gone += gone->skipped.load();
  sent_gone += gone->sent.load();
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

  mg_init_library(0);
  const std::string ports = fmt::format("{}:{}", m.o.bind, m.o.port);
  const std::string threads = std::to_string(m.o.threads);
  const char* opts[] = {"listening_ports", ports.c_str(), "num_threads", threads.c_str(), "request_timeout_ms", "10000",
                        "websocket_timeout_ms", "86400000", "enable_keep_alive", "no", nullptr};
  mg_callbacks cb{};
  cb.log_message = [](const mg_connection*, const char*) { return 1; };  // civetweb's own log: quiet
  m.ctx = mg_start(&cb, &m, opts);
  if (!m.ctx) throw InputError::field("port", fmt::format("cannot listen on {}:{} (in use, or not an address of this machine)", m.o.bind, m.o.port));
  mg_server_port sp[4];
  const int n = mg_get_server_ports(m.ctx, 4, sp);
  m.port = n > 0 ? sp[0].port : m.o.port;

  const auto handler = [](mg_connection* c, void* data) { return static_cast<Impl*>(data)->handle(c); };
  mg_set_request_handler(m.ctx, "/", handler, &m);
  mg_set_request_handler(m.ctx, "/api", handler, &m);
  for (const auto& [name, bytes] : m.files) mg_set_request_handler(m.ctx, ("/" + name).c_str(), handler, &m);
  mg_set_websocket_handler(
      m.ctx, "/api/live",
      [](const mg_connection* c, void* data) { return static_cast<Impl*>(data)->ws_connect(const_cast<mg_connection*>(c)); },
      [](mg_connection* c, void* data) { static_cast<Impl*>(data)->ws_ready(c); },
      [](mg_connection*, int, char*, size_t, void*) { return 1; },  // what viewers send is ignored
      [](const mg_connection* c, void* data) { static_cast<Impl*>(data)->ws_close(c); }, &m);
  m.streamer = std::thread([&m] { m.stream(); });
}

Server::~Server() {
  Impl& m = *impl_;
  m.streaming = false;
  if (m.streamer.joinable()) m.streamer.join();
  {
    const std::lock_guard<std::mutex> lock(m.viewers_mutex);
    for (const auto& v : m.viewers) {
      const std::lock_guard<std::mutex> vl(v->m);
      v->closing = true;
      v->cv.notify_one();
    }
  }
  if (m.ctx) mg_stop(m.ctx);  // closes every connection; ws_close joins each writer
  const std::lock_guard<std::mutex> lock(m.viewers_mutex);
  for (const auto& v : m.viewers)
    if (v->writer.joinable()) v->writer.join();
}

int Server::port() const { return impl_->port; }
const std::string& Server::token() const { return impl_->token; }
std::string Server::url() const { return fmt::format("http://{}:{}/?token={}", impl_->o.bind, impl_->port, impl_->token); }

Server::Counters Server::counters() const {
  Counters c;
  c.frames = impl_->frames.load();
  c.skipped = impl_->skipped_gone.load();
  c.sent = impl_->sent_gone.load();
  const std::lock_guard<std::mutex> lock(impl_->viewers_mutex);
  for (const auto& v : impl_->viewers) c.skipped += v->skipped.load(), c.sent += v->sent.load();
  c.viewers = static_cast<int>(impl_->viewers.size());
  return c;
}

}  // namespace machplan::panel
