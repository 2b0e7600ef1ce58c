// The panel server's routes: what a request's head decides before its body is read, then the
// JSON API (docs/panel.md's table) and the page's files.
#include <strings.h>

#include <algorithm>
#include <cctype>
#include <cstring>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/panel/server_impl.h"
#include "engine/common/error.h"
#include "engine/common/names.h"
#include "engine/common/internal/text_scan.h"
#include "engine/executor/guard.h"

namespace machplan::panel {

using nlohmann::json;

Reply error(int code, const std::string& message) {
  return {code, json{{"error", message}}.dump(-1, ' ', false, json::error_handler_t::replace) + "\n"};
}

Reply ok(const json& j) { return {200, j.dump(-1, ' ', false, json::error_handler_t::replace) + "\n"}; }

namespace {

// Constant time in the length of `expected`.
bool same_token(const std::string& given, const std::string& expected) {
  unsigned char diff = given.size() == expected.size() ? 0 : 1;
  for (std::size_t i = 0; i < expected.size(); ++i) diff |= static_cast<unsigned char>(expected[i] ^ (i < given.size() ? given[i] : 0));
  return diff == 0;
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

// A point [x, y] in mm, or none when `p` is not one.
std::optional<Eigen::Vector2d> xy(const json& p) {
  if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number()) return std::nullopt;
  return Eigen::Vector2d(p[0].get<double>(), p[1].get<double>());
}

// POST /api/job's body (Panel::load_job checks the values).
JobRequest job_request(const json& body) {
  JobRequest r;
  r.program = body.at("program").get<std::string>();
  if (body.contains("name")) r.name = body.at("name").get<std::string>();
  if (body.contains("origin") && !body.at("origin").is_null()) {
    r.origin_mm = xy(body.at("origin"));
    if (!r.origin_mm) throw InputError::field("origin", "must be [x, y] in mm");
  }
  if (body.contains("align") && !body.at("align").is_null()) {
    const json& a = body.at("align");
    const std::optional<Eigen::Vector2d> first = a.is_array() && a.size() == 2 ? xy(a[0]) : std::nullopt,
                                         second = a.is_array() && a.size() == 2 ? xy(a[1]) : std::nullopt;
    if (!first || !second)
      throw InputError::field("align", "must be [[x1, y1], [x2, y2]]: two points on the sheet's edge, mm");
    r.align_mm = std::make_pair(*first, *second);
  }
  if (body.contains("materials") && !body.at("materials").is_null()) r.materials = body.at("materials").get<std::string>();
  r.material = whole_number(body, "material", 0, 999999, "material number").value_or(-1);
  return r;
}

// POST /api/consumables: who changed them is the body's "who", else the panel.
Reply consumables_changed(Panel& panel, const json& body) {
  const auto it = body.find("who");
  if (it != body.end() && (!it->is_string() || it->get<std::string>().empty() || it->get<std::string>().size() > 64))
    throw InputError::field("who", "takes {\"who\": NAME}: 1 to 64 characters");
  panel.consumables_changed(it != body.end() ? it->get<std::string>() : "panel");
  return ok({{"ok", true}, {"statistics", panel.statistics()}});
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
    {"/reset", false, true, true},    {"/override", false, true, true}, {"/paused_motion", false, true, true},
    {"/thc", false, true, true},      {"/jog", false, true, true},      {"/report", true, false, false},
    {"/guard", true, true, true},     {"/history", true, false, false}, {"/frame", false, true, true},
    {"/torch", false, true, true},    {"/statistics", true, false, false}, {"/consumables", false, true, true},
    {"/recover", false, true, true}};  // the older name of /paused_motion

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
    if (e.option() == "align_mm") return error(422, panel.clean(Infeasible(e.message(), "the sheet edge's points").what()));
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
  if (get && path == "/statistics") return ok(panel.statistics());
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
  if (path == "/job") return ok(panel.load_job(job_request(body)));
  if (path == "/run") {
    panel.run(whole_number(body, "from_line", 1, 10000000, "line number"));
    return ok({{"ok", true}});
  }
  if (path == "/frame") {
    const bool laser = body.contains("laser") && body.at("laser").get<bool>();
    return ok({{"ok", true}, {"frame", panel.frame(number(body, "feed"), number(body, "margin"), laser)}});
  }
  if (path == "/consumables") return consumables_changed(panel, body);
  if (path == "/hold") return panel.hold(), ok({{"ok", true}});
  if (path == "/resume") return panel.resume(), ok({{"ok", true}});
  if (path == "/stop") return panel.stop(), ok({{"ok", true}});
  if (path == "/reset") return panel.reset(), ok({{"ok", true}});
  if (path == "/override") {
    panel.set_overrides(number(body, "feed"), number(body, "rapid"));
    return ok({{"ok", true}});
  }
  if (path == "/paused_motion" || path == "/recover") {
    panel.paused_motion(number(body, "mm"), number(body, "speed"));
    return ok({{"ok", true}});
  }
  if (path == "/thc" || path == "/torch") {
    const auto it = body.find("enabled");
    if (it == body.end() || !it->is_boolean()) throw InputError::field("enabled", "takes {\"enabled\": true|false}");
    (path == "/thc" ? panel.set_thc(it->get<bool>()) : panel.set_torch(it->get<bool>()));
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

}  // namespace machplan::panel
