// The panel's API (docs/panel.md) through real HTTP and WebSocket connections to a server on an
// ephemeral loopback port: every route, the token, control, the E-stop, bad and malformed
// requests, the live stream, jog, run from a line, the hybrid mode, and the L bracket held
// and resumed mid-cut against `machplan run`'s figures.
#include <sys/socket.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <set>
#include <string>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "solvers/motion/run.h"
#include "tests/panel/panel_test_rig.h"
#include "tests/support/cli_run.h"

namespace machplan {
namespace {

using nlohmann::json;
using test::HttpResponse;
using test::PanelRig;

const char* const kTriangle = "datasets/parts/triangle_45.ngc";

struct Route {
  const char* method;
  const char* path;
};
const Route kRoutes[] = {{"GET", "/api/status"},   {"POST", "/api/login"},    {"POST", "/api/control"}, {"POST", "/api/job"},
                         {"GET", "/api/job"},      {"POST", "/api/run"},      {"POST", "/api/hold"},    {"POST", "/api/resume"},
                         {"POST", "/api/stop"},    {"POST", "/api/estop"},    {"POST", "/api/reset"},   {"POST", "/api/override"},
                         {"POST", "/api/paused_motion"}, {"POST", "/api/recover"}, {"POST", "/api/thc"}, {"POST", "/api/torch"},
                         {"POST", "/api/jog"},     {"GET", "/api/report"},    {"POST", "/api/guard"},   {"GET", "/api/guard"},
                         {"GET", "/api/history"},  {"POST", "/api/frame"}};

TEST(PanelApi, EveryRouteWantsTheTokenAndAnswers401AndNothingElse) {
  PanelRig rig(0);
  for (const Route& r : kRoutes) {
    for (const test::Headers& h : {test::Headers{}, test::Headers{{"Authorization", "Bearer " + std::string(64, 'a')}},
                                   test::Headers{{"Authorization", "Bearer " + rig.token + "x"}},
                                   test::Headers{{"Authorization", "Basic " + rig.token}},
                                   test::Headers{{"Cookie", "machplan_token=" + rig.token.substr(1)}}}) {
      const HttpResponse a = test::http(rig.port, r.method, r.path, h, r.method == std::string("POST") ? "{}" : "");
      EXPECT_EQ(a.status, 401) << r.method << " " << r.path;
      EXPECT_EQ(a.body, "") << r.path;
      EXPECT_EQ(a.headers.count("set-cookie"), 0u);
    }
  }
  // Nothing happened: no job, no estop, idle.
  const json s = rig.status();
  EXPECT_EQ(s["job_id"], 0);
  EXPECT_EQ(s["estop"], false);
  EXPECT_EQ(s["state"], "idle");
}

TEST(PanelApi, StatusHasTheFieldsAnOperatorReads) {
  PanelRig rig(0);
  const json s = rig.status();
  for (const char* k : {"machine", "state", "program", "line", "position_mm", "feed_mm_per_s", "overrides", "torch", "progress",
                        "time_left_s", "faults", "estop", "control", "backend"})
    EXPECT_TRUE(s.contains(k)) << k;
  EXPECT_EQ(s["machine"], "thermal_gantry");
  EXPECT_EQ(s["state"], "idle");
  EXPECT_EQ(s["overrides"]["feed_pct"], 100.0);
}

TEST(PanelApi, ThePageIsServedWithoutTheTokenAndNothingElseIs) {
  PanelRig rig(0);
  const HttpResponse page = test::http(rig.port, "GET", "/");
  EXPECT_EQ(page.status, 200);
  EXPECT_NE(page.body.find("panel.js"), std::string::npos);
  EXPECT_NE(page.headers.at("content-security-policy").find("frame-ancestors 'none'"), std::string::npos);
  EXPECT_EQ(test::http(rig.port, "GET", "/panel.js").status, 200);
  EXPECT_EQ(test::http(rig.port, "GET", "/../../etc/passwd").status, 404);
  EXPECT_EQ(test::http(rig.port, "GET", "/nothing.html").status, 404);
  EXPECT_EQ(test::http(rig.port, "POST", "/").status, 405);
  // A Host that is not loopback (DNS rebinding) is refused.
  EXPECT_EQ(test::http(rig.port, "GET", "/api/status", {{"Host", "evil.example:80"}, {"Authorization", "Bearer " + rig.token}}).status,
            403);
}

TEST(PanelApi, LoginSetsACookieThatWorksFromThePageOnly) {
  PanelRig rig(0);
  const HttpResponse login = test::http(rig.port, "POST", "/api/login", {{"Authorization", "Bearer " + rig.token}});
  ASSERT_EQ(login.status, 200);
  const std::string cookie = login.headers.at("set-cookie");
  EXPECT_NE(cookie.find("HttpOnly"), std::string::npos);
  EXPECT_NE(cookie.find("SameSite=Strict"), std::string::npos);
  const std::string value = cookie.substr(0, cookie.find(';'));
  EXPECT_EQ(test::http(rig.port, "GET", "/api/status", {{"Cookie", value}}).status, 200);
  const std::string origin = "http://127.0.0.1:" + std::to_string(rig.port);
  const test::Headers page = {{"Cookie", value}, {"Origin", origin}, {"Content-Type", "application/json"}, {"X-Machplan-Client", "page-client"}};
  EXPECT_EQ(test::http(rig.port, "POST", "/api/control", page, "{}").status, 200);
  // Cross-site: another origin, no origin, or a form's content type.
  test::Headers evil = page;
  evil[1].second = "http://evil.example";
  EXPECT_EQ(test::http(rig.port, "POST", "/api/estop", evil, "{}").status, 403);
  EXPECT_EQ(test::http(rig.port, "POST", "/api/estop", {{"Cookie", value}}, "{}").status, 403);
  test::Headers form = page;
  form[2].second = "application/x-www-form-urlencoded";
  EXPECT_EQ(test::http(rig.port, "POST", "/api/estop", form, "a=b").status, 415);
  EXPECT_EQ(rig.status()["estop"], false);
}

TEST(PanelApi, CutRecoveryAndTheThcSwitchTakeTheirValuesAndRefuseOthers) {
  PanelRig rig(0);
  rig.take_control();
  EXPECT_EQ(rig.status()["thc_enabled"], true);
  EXPECT_EQ(rig.post("/api/thc", {{"enabled", false}}).status, 200);
  EXPECT_EQ(rig.status()["thc_enabled"], false);
  EXPECT_EQ(rig.post("/api/thc", {{"enabled", "no"}}).status, 400);
  EXPECT_EQ(rig.post("/api/thc", json::object()).status, 400);
  EXPECT_EQ(rig.status()["thc_enabled"], false);
  EXPECT_EQ(rig.status()["torch_enabled"], true);
  EXPECT_EQ(rig.post("/api/torch", {{"enabled", false}}).status, 200);
  EXPECT_EQ(rig.status()["torch_enabled"], false);
  EXPECT_EQ(rig.post("/api/torch", {{"enabled", 0}}).status, 400);
  EXPECT_EQ(rig.post("/api/torch", {{"enabled", true}}).status, 200);
  EXPECT_EQ(rig.status()["torch_enabled"], true);
  EXPECT_EQ(rig.post("/api/paused_motion", {{"mm", -3.5}}).status, 200);
  EXPECT_EQ(rig.post("/api/paused_motion", {{"speed", -0.5}}).status, 200);
  EXPECT_EQ(rig.post("/api/recover", {{"mm", 2}}).status, 200) << "the older name";
  for (const json& bad : {json{{"mm", 0}}, json{{"mm", 5000}}, json{{"mm", "back"}}, json::object(), json{{"speed", 1.5}},
                          json{{"mm", -1}, {"speed", 0.5}}})
    EXPECT_EQ(rig.post("/api/paused_motion", bad).status, 400) << bad.dump();
  EXPECT_EQ(rig.post("/api/paused_motion", {{"mm", -1}}, "client-two").status, 409) << "needs control";
}

TEST(PanelApi, ControlIsTakenExplicitlyAndTheEstopIsEveryones) {
  PanelRig rig(0);
  EXPECT_EQ(rig.post("/api/job", {{"program", kTriangle}}).status, 409) << "nobody holds control yet";
  rig.take_control("client-one");
  EXPECT_EQ(rig.status()["control"]["yours"], true);
  EXPECT_EQ(rig.post("/api/job", {{"program", kTriangle}}, "client-two").status, 409);
  EXPECT_EQ(rig.post("/api/override", {{"feed", 50}}, "client-two").status, 409);
  EXPECT_EQ(rig.post("/api/job", {{"program", kTriangle}}, "client-one").status, 200);
  EXPECT_EQ(rig.post("/api/control", json::object(), "bad id").status, 400);
  // Another client takes control: the first one watches from now on.
  rig.take_control("client-two");
  EXPECT_EQ(rig.post("/api/run", json::object(), "client-one").status, 409);
  // The E-stop needs no control.
  EXPECT_EQ(rig.post("/api/estop", json::object(), "client-one").status, 200);
  EXPECT_EQ(rig.status()["estop"], true);
  EXPECT_EQ(rig.post("/api/run", json::object(), "client-two").status, 409) << "the E-stop is latched";
  EXPECT_EQ(rig.post("/api/reset", json::object(), "client-two").status, 200);
  EXPECT_EQ(rig.status()["estop"], false);
}

TEST(PanelApi, BadRequestsGet4xxWithAMessageAndChangeNothing) {
  PanelRig rig(0);
  rig.take_control();
  const json before = rig.status();
  const auto bad = [&](const std::string& path, const std::string& body, int code, const std::string& says) {
    const HttpResponse r = test::http(rig.port, "POST", path, rig.auth(), body);
    EXPECT_EQ(r.status, code) << path << " " << body.substr(0, 80) << " -> " << r.body;
    if (!says.empty()) EXPECT_NE(r.body.find(says), std::string::npos) << r.body;
    if (code != 401) EXPECT_TRUE(json::parse(r.body, nullptr, false).contains("error")) << r.body;
  };
  bad("/api/job", "{not json", 400, "not valid JSON");
  bad("/api/job", "[1,2]", 400, "JSON object");
  bad("/api/job", "{\"program\": 5}", 400, "wrong type");
  bad("/api/job", "{}", 400, "");
  bad("/api/job", "{\"program\": \"no/such/file.ngc\"}", 400, "no/such/file.ngc");
  bad("/api/job", json{{"program", "G21 G90\nG1 X10 Y10 F100\nG1 XA10\nM2\n"}, {"name", "part.ngc"}}.dump(), 400, "part.ngc:3");
  bad("/api/job", json{{"program", kTriangle}, {"origin", {1}}}.dump(), 400, "origin");
  bad("/api/job", json{{"program", kTriangle}, {"origin", {"a", 2}}}.dump(), 400, "origin");
  bad("/api/job", json{{"program", kTriangle}, {"material", 3}}.dump(), 400, "no material file is given");
  bad("/api/job", json{{"program", kTriangle}, {"material", 1.5}}.dump(), 400, "whole number");
  bad("/api/job", json{{"program", kTriangle}, {"materials", 4}}.dump(), 400, "wrong type");
  bad("/api/job", json{{"program", kTriangle}, {"origin", {1e9, 0}}}.dump(), 400, "origin");
  // A job off the machine: the refusal names the origin fields that move it on.
  bad("/api/job", json{{"program", kTriangle}, {"origin", {-500, 0}}}.dump(), 422, "move the zero there with the origin X, Y fields");
  // A sheet alignment: two points, apart, not beside an origin; one that puts the job off the
  // machine names the points that move it on.
  bad("/api/job", json{{"program", kTriangle}, {"align", {{1, 2}}}}.dump(), 400, "[[x1, y1], [x2, y2]]");
  bad("/api/job", json{{"program", kTriangle}, {"align", {{1, 2}, {3, "a"}}}}.dump(), 400, "align");
  bad("/api/job", json{{"program", kTriangle}, {"align", {{100, 100}, {110, 100}}}}.dump(), 400, "10.000 mm apart");
  bad("/api/job", json{{"program", kTriangle}, {"align", {{100, 100}, {200, 100}}}, {"origin", {5, 5}}}.dump(), 400, "not both");
  bad("/api/job", json{{"program", kTriangle}, {"align", {{-400, 100}, {-300, 100}}}}.dump(), 422, "with the sheet edge's points");
  bad("/api/override", "{\"feed\": 250}", 400, "0 .. 200");
  bad("/api/override", "{\"rapid\": 0}", 400, "1 .. 100");
  bad("/api/override", "{\"feed\": \"fast\"}", 400, "number");
  bad("/api/jog", "{\"x\": 3}", 400, "-1 .. 1");
  bad("/api/run", "{\"from_line\": 1.5}", 400, "whole number");
  bad("/api/run", "{\"from_line\": -4}", 400, "line number");
  bad("/api/run", "{}", 409, "no job");
  bad("/api/guard", "{\"profile\": \"x.dxf\"}", 400, "");
  bad("/api/guard", json{{"profile", "datasets/profiles/paper_triangle.dxf"}, {"side", "sideways"}, {"tool_radius_mm", 5}, {"tolerance_mm", 4}}.dump(), 400,
      "sideways");
  bad("/api/nothing", "{}", 404, "no route");
  bad("/api/override", std::string(70 * 1024, ' '), 413, "larger");
  EXPECT_EQ(rig.get("/api/run").status, 405);
  EXPECT_EQ(test::http(rig.port, "DELETE", "/api/status", rig.auth()).status, 405);
  EXPECT_EQ(rig.get("/api/report").status, 404);
  EXPECT_EQ(rig.get("/api/job").status, 404);
  const json after = rig.status();
  for (const char* k : {"job_id", "state", "estop", "position_mm", "overrides", "activity"}) EXPECT_EQ(after[k], before[k]) << k;
}

// Files a request may read: only regular files of the kind asked for, from the job folder, the
// bundled datasets and the uploads. A marker planted in files the panel must not read (outside
// those folders, or of another kind) appears in no answer; a missing file, a file outside, a
// folder and a FIFO get one and the same refusal, at once (no writer ever opens the FIFO).
TEST(PanelApi, AFileOutsideTheFoldersOrOfAnotherKindIsNeverQuoted) {
  test::TempDir jobs, outside;
  PanelRig rig(0, "thermal_gantry", [&](panel::PanelOptions& po) { po.job_folder = jobs.path().string(); });
  rig.take_control();
  const std::string marker = "root:MARKER-5ec7e7:20228:0:99999:7";
  const std::string secret_cfg = outside.write("secret.cfg", marker + "\n");
  const std::string secret_ngc = outside.write("secret.ngc", marker + "\n");
  const std::string secret_dxf = outside.write("secret.dxf", marker + "\n");
  const std::string notes = jobs.write("notes.txt", marker + "\n");
  const std::string program_as_materials = jobs.write("part.ngc", marker + "\n");
  const std::string fifo = (jobs.path() / "pipe.ngc").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string folder_ngc = (jobs.path() / "folder.ngc").string();
  std::filesystem::create_directory(folder_ngc);
  const auto answer = [&](const std::string& path, const json& body) {
    const HttpResponse r = rig.post(path, body);
    EXPECT_EQ(r.status, 400) << body.dump() << " -> " << r.body;
    EXPECT_EQ(r.body.find("MARKER-5ec7e7"), std::string::npos) << body.dump() << " -> " << r.body;
    return json::parse(r.body, nullptr, false).value("error", std::string());
  };
  const auto same_refusal = [&](const std::string& text, const std::string& path) {
    std::string t = text;
    const std::size_t at = t.find(path);
    EXPECT_NE(at, std::string::npos) << t;
    if (at != std::string::npos) t.replace(at, path.size(), "PATH");
    return t;
  };
  const std::string missing = (jobs.path() / "missing.ngc").string();
  const std::string refusal = same_refusal(answer("/api/job", {{"program", missing}}), missing);
  EXPECT_NE(refusal.find("no readable program by that name in the job folder, the bundled datasets or the uploads"),
            std::string::npos)
      << refusal;
  for (const std::string& p : {secret_ngc, fifo, folder_ngc, std::string("/etc/../etc/passwd.ngc")})
    EXPECT_EQ(same_refusal(answer("/api/job", {{"program", p}}), p), refusal) << p;
  // Files of another kind are refused by their name, before anything is opened.
  for (const std::string& p : {notes, program_as_materials, std::string("/etc/shadow")})
    EXPECT_NE(answer("/api/job", {{"program", kTriangle}, {"materials", p}}).find("is not a material file"), std::string::npos) << p;
  EXPECT_NE(answer("/api/job", {{"program", notes}}).find("is not a program"), std::string::npos);
  answer("/api/job", {{"program", kTriangle}, {"materials", secret_cfg}});
  const json guard = {{"profile", secret_dxf}, {"side", "outside"}, {"tool_radius_mm", 5}, {"tolerance_mm", 4}};
  EXPECT_NE(answer("/api/guard", guard).find("no readable DXF profile"), std::string::npos);
  json by_path = guard;
  by_path["profile"] = "datasets/profiles/paper_triangle.dxf";
  by_path["machine"] = secret_cfg;
  EXPECT_NE(answer("/api/guard", by_path).find("takes a machine by its name"), std::string::npos);
  // None of that held the planning lock: a job from the bundled datasets loads at once.
  rig.load({{"program", kTriangle}});
}

// Each route takes the methods docs/panel.md gives it: POST on a GET-only route is 405, as GET
// on a POST-only one is.
TEST(PanelApi, AWrongMethodIs405OnEveryRoute) {
  PanelRig rig(0);
  rig.take_control();
  for (const Route& r : kRoutes) {
    const bool get = std::string(r.method) == "GET";
    const bool both = std::any_of(std::begin(kRoutes), std::end(kRoutes), [&](const Route& o) {
      return std::string(o.path) == r.path && std::string(o.method) != r.method;
    });
    if (both) continue;
    const HttpResponse h = test::http(rig.port, get ? "POST" : "GET", r.path, rig.auth(), get ? "{}" : "");
    EXPECT_EQ(h.status, 405) << (get ? "POST " : "GET ") << r.path << " -> " << h.body;
  }
  for (const char* method : {"PUT", "DELETE", "PATCH"})
    EXPECT_EQ(test::http(rig.port, method, "/api/job", rig.auth(), "{}").status, 405) << method;
}

// A whole number beyond 64 signed bits is refused as sent, never echoed wrapped to a negative.
TEST(PanelApi, AnOutOfRangeWholeNumberIsQuotedAsSent) {
  PanelRig rig(0);
  rig.take_control();
  const std::string body = R"({"program": "datasets/parts/triangle_45.ngc", "material": 9223372036854775808})";
  const HttpResponse r = test::http(rig.port, "POST", "/api/job", rig.auth(), body);
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_NE(r.body.find("9223372036854775808 is not a material number (0 to 999999)"), std::string::npos) << r.body;
  EXPECT_EQ(r.body.find("-9223372036854775808"), std::string::npos) << r.body;
  const HttpResponse line = test::http(rig.port, "POST", "/api/run", rig.auth(), R"({"from_line": 18446744073709551615})");
  EXPECT_EQ(line.status, 400) << line.body;
  EXPECT_NE(line.body.find("18446744073709551615 is not a line number"), std::string::npos) << line.body;
}

// Parsing is bounded: a command from a client not in control is refused before its body is
// parsed (bad JSON from it gets 409, not 400), and JSON nested deeper than 64 levels is refused
// before the parser builds it; 64 levels still parse (and get the route's own answer).
TEST(PanelApi, ControlAndNestingAreCheckedBeforeTheBodyIsParsed) {
  PanelRig rig(0);
  EXPECT_EQ(test::http(rig.port, "POST", "/api/job", rig.auth("client-two"), "{not json").status, 409);
  rig.take_control();
  EXPECT_EQ(test::http(rig.port, "POST", "/api/job", rig.auth(), "{not json").status, 400);
  const auto nested = [](int depth) {
    return "{\"program\": " + std::string(static_cast<std::size_t>(depth - 1), '[') + std::string(static_cast<std::size_t>(depth - 1), ']') + "}";
  };
  const HttpResponse deep = test::http(rig.port, "POST", "/api/job", rig.auth(), nested(65));
  EXPECT_EQ(deep.status, 400);
  EXPECT_NE(deep.body.find("deeper than 64 levels"), std::string::npos) << deep.body;
  const HttpResponse bomb = test::http(rig.port, "POST", "/api/job", rig.auth(), nested(4'000'000));
  EXPECT_EQ(bomb.status, 400);
  EXPECT_NE(bomb.body.find("deeper than 64 levels"), std::string::npos) << bomb.body.substr(0, 200);
  const HttpResponse ok64 = test::http(rig.port, "POST", "/api/job", rig.auth(), nested(64));
  EXPECT_EQ(ok64.status, 400);
  EXPECT_NE(ok64.body.find("wrong type"), std::string::npos) << ok64.body;  // parsed, then refused by the route
  // Brackets inside strings are text, not nesting.
  const HttpResponse text = test::http(rig.port, "POST", "/api/job", rig.auth(),
                                       "{\"program\": \"" + std::string(100, '[') + "\\\"]\"}");
  EXPECT_EQ(text.body.find("deeper than"), std::string::npos) << text.body;
}

// Host names are case-insensitive: LOCALHOST is this server; a foreign name still is not.
TEST(PanelApi, TheHostCheckIgnoresCase) {
  PanelRig rig(0);
  const auto with_host = [&](const std::string& host) {
    return test::http(rig.port, "GET", "/api/status", {{"Host", host}, {"Authorization", "Bearer " + rig.token}}).status;
  };
  EXPECT_EQ(with_host("LOCALHOST"), 200);
  EXPECT_EQ(with_host(fmt::format("LocalHost:{}", rig.port)), 200);
  EXPECT_EQ(with_host("EVIL.example"), 403);
}

TEST(PanelApi, FuzzedAndMalformedRequestsNeverCrashTheServerOrMoveTheMachine) {
  PanelRig rig(0);
  rig.take_control();
  ASSERT_EQ(rig.post("/api/job", {{"program", kTriangle}}).status, 200);
  const json before = rig.status();
  std::mt19937_64 rng(7);
  const std::string auth = "Authorization: Bearer " + rig.token + "\r\nX-Machplan-Client: client-one\r\n";
  const std::vector<std::string> paths = {"/api/job", "/api/run", "/api/override", "/api/jog", "/api/hold", "/api/status",
                                          "/api/guard", "/api/live", "/", "/api/control"};
  const std::vector<std::string> bodies = {"{", "}", "null", "[]", "{\"program\":[]}", "{\"feed\":1e999}", "{\"x\":null,\"y\":{}}",
                                           "{\"from_line\":99999999999}", "\"str\"", std::string(1000, '{'), "{\"origin\":[1,2,3]}"};
  int answered = 0;
  for (int i = 0; i < 300; ++i) {
    std::string req;
    switch (i % 6) {
      case 0: {  // random bytes
        req.resize(rng() % 400);
        for (char& c : req) c = static_cast<char>(rng());
        break;
      }
      case 1:  // a request line cut short
        req = "POST /api/jo";
        break;
      case 2: {  // a body that lies about its length (the longer side times out)
        const std::string& b = bodies[rng() % bodies.size()];
        std::string p = paths[rng() % paths.size()];
        if (p == "/api/run" || p == "/api/hold") p = "/api/job";  // valid with an empty body: they would run
        req = "POST " + p + " HTTP/1.1\r\nHost: 127.0.0.1\r\n" + auth +
              "Content-Length: " + std::to_string(b.size() / 2) + "\r\n\r\n" + b;
        break;
      }
      case 3: {  // well-formed, wrong bodies (no run command: a run would move the machine legitimately)
        std::string p = paths[rng() % paths.size()];
        if (p == "/api/run" || p == "/api/hold") p = "/api/override";
        const std::string& b = bodies[rng() % bodies.size()];
        req = "POST " + p + " HTTP/1.1\r\nHost: 127.0.0.1\r\n" + auth + "Content-Length: " + std::to_string(b.size()) + "\r\n\r\n" + b;
        break;
      }
      case 4:  // headers far too long
        req = "GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Junk: " + std::string(200000, 'x') + "\r\n\r\n";
        break;
      case 5:  // a chunked body that never ends properly
        req = "POST /api/override HTTP/1.1\r\nHost: 127.0.0.1\r\n" + auth +
              "Transfer-Encoding: chunked\r\n\r\nFFFFFFFF\r\n{\"feed\":";
        break;
    }
    const std::string reply = test::send_raw(rig.port, req, 2.0);
    if (!reply.empty()) ++answered;
  }
  EXPECT_GT(answered, 100);
  const json after = rig.status();
  for (const char* k : {"job_id", "state", "estop", "position_mm", "activity"}) EXPECT_EQ(after[k], before[k]) << k;
  EXPECT_EQ(after["overrides"]["feed_pct"], 100.0);
}

TEST(PanelApi, StalledClientsHoldNoOneElseBackAndChangeNothing) {
  PanelRig rig(0);
  rig.take_control();
  const std::string auth = "Authorization: Bearer " + rig.token + "\r\nX-Machplan-Client: client-one\r\n";
  std::vector<std::unique_ptr<test::StalledClient>> stalled;
  for (int i = 0; i < 24; ++i) {
    // A head that never ends, and a body that stops before its length.
    const std::string bytes = i % 2 ? "GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: "
                                    : "POST /api/override HTTP/1.1\r\nHost: 127.0.0.1\r\n" + auth +
                                          "Content-Type: application/json\r\nContent-Length: 40\r\n\r\n{\"feed\": 1";
    stalled.push_back(std::make_unique<test::StalledClient>(rig.port, bytes));
    ASSERT_TRUE(stalled.back()->connected());
  }
  // The others are served meanwhile, commands included.
  for (int i = 0; i < 10; ++i) EXPECT_EQ(rig.get("/api/status").status, 200);
  ASSERT_EQ(rig.post("/api/override", {{"feed", 60}}).status, 200);
  EXPECT_EQ(rig.status()["overrides"]["feed_pct"], 60.0);
  stalled.clear();  // they give up: the half-sent overrides were never applied
  EXPECT_EQ(rig.get("/api/status").status, 200);
  const json s = rig.status();
  EXPECT_EQ(s["overrides"]["feed_pct"], 60.0);
  EXPECT_EQ(s["activity"], "idle");
}

TEST(PanelApi, TheTriangleRunsHoldsResumesAndReports) {
  // Twice real time: the cut lasts about 4 s of wall clock, far longer than a status poll takes
  // on a loaded machine, so the test cannot miss it.
  PanelRig rig(2.0);
  rig.take_control();
  const json job = rig.load({{"program", kTriangle}});
  EXPECT_EQ(job["source"], kTriangle);
  const json drawing = json::parse(rig.get("/api/job").body);
  EXPECT_EQ(drawing["parts"].size(), 1u);
  EXPECT_EQ(drawing["pierces"].size(), 1u);
  EXPECT_EQ(drawing["bounds"]["max"][0], 300.0);
  ASSERT_EQ(rig.post("/api/run").status, 200);
  EXPECT_EQ(rig.post("/api/run").status, 409) << "one run at a time";
  EXPECT_EQ(rig.post("/api/job", {{"program", kTriangle}}).status, 409) << "no load while running";
  // Cutting: the arc burns and the tool moves (not the pierce, when a hold waits for the dwell).
  ASSERT_TRUE(rig.wait_for([](const json& s) { return s["torch"]["arc_ok"] == true && s["feed_mm_per_s"].get<double>() > 10; }));
  const json cutting = rig.status();
  EXPECT_EQ(cutting["state"], "running");
  EXPECT_GT(cutting["line"].get<int>(), 0);
  ASSERT_EQ(rig.post("/api/hold").status, 200);
  ASSERT_TRUE(rig.wait_for([](const json& s) { return s["state"] == "held" && s["feed_mm_per_s"] == 0.0; }));
  const json held = rig.status();
  EXPECT_EQ(held["torch"]["fire"], false) << "the hold turned the torch off in the cut";
  ASSERT_EQ(rig.post("/api/resume").status, 200);
  json last;
  ASSERT_TRUE(rig.wait_for([&](const json& s) {
    last = s;
    return s["state"] == "done";
  })) << last.dump();
  EXPECT_EQ(last["progress"], 1.0) << "a run that ended done is all done, not 99.9 %";
  const HttpResponse rep = rig.get("/api/report");
  ASSERT_EQ(rep.status, 200);
  const json r = json::parse(rep.body);
  EXPECT_EQ(r["status"], "done");
  ASSERT_EQ(r["holds"].size(), 1u);
  EXPECT_EQ(r["holds"][0]["in_cut"], true);
  EXPECT_EQ(r["torch_off_at_end"], true);
  EXPECT_TRUE(r.contains("cut_order"));
  // Again: the job runs a second time from where the first left the machine.
  ASSERT_EQ(rig.post("/api/run").status, 200);
  ASSERT_TRUE(rig.wait_for([&](const json&) { return rig.panel->runs_finished() == 2; }));
  EXPECT_EQ(json::parse(rig.get("/api/report").body)["status"], "done");
}

// A sheet program `machplan nest` wrote loads like any program: every pierce and the parts drawn,
// within the sheet.
TEST(PanelApi, ASheetProgramFromNestLoadsLikeAnyProgram) {
  test::TempDir jobs;
  const test::Cli cli;
  const test::CliResult n = cli.run(fmt::format("nest '{}' --time 1 --out '{}' --json",
                                                test::source_path("datasets/nesting/sheet_job.yaml"), jobs.path().string()));
  ASSERT_EQ(n.code, 0) << n.err;
  const json nest = json::parse(n.out);
  const std::string program = nest["sheets"][0]["program"];
  PanelRig rig(0, "thermal_gantry", [&](panel::PanelOptions& po) { po.job_folder = jobs.path().string(); });
  rig.take_control();
  const json job = rig.load({{"program", program}});
  EXPECT_EQ(job["source"], program);
  const json drawing = json::parse(rig.get("/api/job").body);
  EXPECT_EQ(drawing["pierces"].size(), nest["sheets"][0]["pierces"].get<std::size_t>());
  EXPECT_GT(drawing["parts"].size(), 0u);
  EXPECT_LE(drawing["bounds"]["max"][0].get<double>(), nest["sheets"][0]["width_mm"].get<double>());
  EXPECT_GE(drawing["bounds"]["min"][0].get<double>(), 0.0);
}

TEST(PanelApi, TheEstopMidCutEndsTorchOffAndLatchesUntilReset) {
  // Twice real time: the cut lasts about 4 s of wall clock, far longer than a status poll takes
  // on a loaded machine, so the test cannot miss it.
  PanelRig rig(2.0);
  rig.take_control("operator");
  ASSERT_EQ(rig.post("/api/job", {{"program", kTriangle}}, "operator").status, 200);
  ASSERT_EQ(rig.post("/api/run", json::object(), "operator").status, 200);
  ASSERT_TRUE(rig.wait_for(
      [](const json& s) { return s["torch"]["arc_ok"] == true && s["feed_mm_per_s"].get<double>() > 10; }));
  ASSERT_EQ(rig.post("/api/estop", json::object(), "a-watcher-without-control").status, 200);
  ASSERT_TRUE(rig.wait_idle());
  const json s = rig.status();
  EXPECT_EQ(s["state"], "faulted");
  EXPECT_EQ(s["estop"], true);
  EXPECT_EQ(s["torch"]["fire"], false);
  ASSERT_FALSE(s["faults"].empty());
  EXPECT_EQ(s["faults"][0]["kind"], "estop");
  const json r = json::parse(rig.get("/api/report").body);
  EXPECT_EQ(r["status"], "faulted");
  EXPECT_EQ(r["faults"][0]["kind"], "estop");
  EXPECT_EQ(r["torch_off_at_end"], true);
  EXPECT_EQ(rig.post("/api/run", json::object(), "operator").status, 409);
  EXPECT_EQ(rig.post("/api/jog", {{"x", 1}}, "operator").status, 409);
  ASSERT_EQ(rig.post("/api/reset", json::object(), "operator").status, 200);
  // The reset acknowledges the fault: the status shows none in force (the report keeps it).
  const json reset = rig.status();
  EXPECT_EQ(reset["estop"], false);
  EXPECT_TRUE(reset["faults"].empty()) << reset.dump();
  EXPECT_EQ(reset["state"], "faulted") << "how the last run ended stays";
  // The job runs again from where the machine stopped (a rapid to its start first).
  ASSERT_EQ(rig.post("/api/run", json::object(), "operator").status, 200);
  ASSERT_TRUE(rig.wait_for([&](const json&) { return rig.panel->runs_finished() == 2; }));
  EXPECT_EQ(json::parse(rig.get("/api/report").body)["status"], "done");
}

TEST(PanelApi, OverridesAndStopReachTheRun) {
  PanelRig rig(8.0);
  rig.take_control();
  rig.load({{"program", kTriangle}});
  ASSERT_EQ(rig.post("/api/override", {{"feed", 50}, {"rapid", 25}}).status, 200);
  ASSERT_EQ(rig.post("/api/run").status, 200);
  test::WsClient ws(rig.port, "/api/live", rig.auth());
  ASSERT_TRUE(ws.ok()) << ws.response();
  bool seen = false;
  for (int i = 0; i < 2000 && !seen; ++i) {
    const json f = json::parse(ws.next_text(), nullptr, false);
    ASSERT_TRUE(f.is_object());
    seen = f["state"] == "running" && f["feed_pct"] == 50.0 && f["rapid_pct"] == 25.0;
  }
  EXPECT_TRUE(seen) << "the overrides reach the executor";
  ASSERT_EQ(rig.post("/api/stop").status, 200);
  ASSERT_TRUE(rig.wait_idle());
  const json r = json::parse(rig.get("/api/report").body);
  EXPECT_EQ(r["faults"][0]["kind"], "operator_stop");
  EXPECT_EQ(r["summary"]["status"], "cancelled");
  EXPECT_EQ(r["torch_off_at_end"], true);
  // The status says how the run really ended, in the summary's spelling, and shows no fault:
  // the stop was asked for.
  const json s = rig.status();
  EXPECT_EQ(s["state"], "cancelled");
  EXPECT_TRUE(s["faults"].empty()) << s.dump();
  // An E-stop pressed now latches until it is reset.
  ASSERT_EQ(rig.post("/api/estop").status, 200);
  EXPECT_EQ(rig.status()["estop"], true);
  ASSERT_EQ(rig.post("/api/reset").status, 200);
  EXPECT_EQ(rig.status()["estop"], false);
  EXPECT_EQ(rig.status()["state"], "cancelled");
}

TEST(PanelApi, AStopPressedAsARunStartsIsNeverLost) {
  // The first run takes the plan made at loading; each later one plans the job again, and a stop
  // can land before, during or after that planning, or before the run's first period: every
  // one must end the run, and none may be left for the next run.
  PanelRig rig(8.0);
  rig.take_control();
  rig.load({{"program", kTriangle}});
  for (int i = 0; i < 8; ++i) {
    ASSERT_EQ(rig.post("/api/run").status, 200);
    if (i % 2 == 1) std::this_thread::sleep_for(std::chrono::milliseconds(5 * i));
    ASSERT_EQ(rig.post("/api/stop").status, 200);
    ASSERT_TRUE(rig.wait_idle());
    const json s = rig.status();
    EXPECT_EQ(s["state"], "cancelled") << "stop " << i << ": " << s.dump();
    EXPECT_TRUE(s["faults"].empty()) << s.dump();
  }
  // A stop pressed on an idle machine stops nothing later.
  ASSERT_EQ(rig.post("/api/stop").status, 200);
  ASSERT_EQ(rig.post("/api/run").status, 200);
  ASSERT_TRUE(rig.wait_idle());
  EXPECT_EQ(rig.status()["state"], "done");
  EXPECT_EQ(json::parse(rig.get("/api/report").body)["torch_off_at_end"], true);
}

// A hold pressed as a run starts (the job planned again: the run after the first) holds that run.
// The press stays until a run has read it, however long the planning takes; only with nothing
// running is it let go after 250 ms. (Here the planning is shorter than that: the test keeps the
// path working, it does not stretch the planning.)
TEST(PanelApi, AHoldPressedAsARunStartsHoldsIt) {
  PanelRig rig(8.0);
  rig.take_control();
  rig.load({{"program", "datasets/parts/nested_sheet.ngc"}});
  ASSERT_EQ(rig.post("/api/run").status, 200);
  ASSERT_EQ(rig.post("/api/stop").status, 200);
  ASSERT_TRUE(rig.wait_idle());
  ASSERT_EQ(rig.post("/api/run").status, 200);
  ASSERT_EQ(rig.post("/api/hold").status, 200);
  ASSERT_TRUE(rig.wait_for([](const json& s) { return s["state"] == "held"; }, 60.0)) << rig.status().dump();
  ASSERT_EQ(rig.post("/api/stop").status, 200);
  ASSERT_TRUE(rig.wait_idle());
  const json r = json::parse(rig.get("/api/report").body);
  EXPECT_EQ(r["summary"]["status"], "cancelled");
  EXPECT_EQ(r["holds"].size(), 1u);
}

TEST(PanelApi, TheLiveStreamWantsTheTokenAndThisOriginAndSendsTheState) {
  PanelRig rig(0);
  {
    test::WsClient none(rig.port, "/api/live");
    EXPECT_FALSE(none.ok());
    EXPECT_EQ(none.response().rfind("HTTP/1.1 401", 0), 0u) << none.response();
  }
  {
    test::WsClient cross(rig.port, "/api/live", {{"Authorization", "Bearer " + rig.token}, {"Origin", "http://evil.example"}});
    EXPECT_FALSE(cross.ok());
    EXPECT_EQ(cross.response().rfind("HTTP/1.1 403", 0), 0u) << cross.response();
  }
  test::WsClient ws(rig.port, "/api/live",
                    {{"Authorization", "Bearer " + rig.token}, {"Origin", "http://127.0.0.1:" + std::to_string(rig.port)}});
  ASSERT_TRUE(ws.ok()) << ws.response();
  for (int i = 0; i < 20; ++i) {
    const json f = json::parse(ws.next_text(), nullptr, false);
    ASSERT_TRUE(f.is_object());
    for (const char* k : {"state", "position_mm", "line", "feed_mm_per_s", "torch", "height_mm", "arc_voltage_v", "progress",
                          "time_left_s", "estop"})
      EXPECT_TRUE(f.contains(k)) << k;
  }
}

TEST(PanelApi, ASlowViewerDoesNotHoldTheOthersBack) {
  PanelRig rig(0);
  std::vector<std::unique_ptr<test::WsClient>> stalled;
  for (int i = 0; i < 4; ++i) {
    stalled.push_back(std::make_unique<test::WsClient>(rig.port, "/api/live", rig.auth()));
    ASSERT_TRUE(stalled.back()->ok());  // and never read from again
  }
  test::WsClient reader(rig.port, "/api/live", rig.auth());
  ASSERT_TRUE(reader.ok());
  for (int i = 0; i < 150; ++i) ASSERT_FALSE(reader.next_text().empty()) << "frame " << i;
  EXPECT_GE(rig.server->counters().viewers, 5);
  EXPECT_EQ(rig.status()["state"], "idle");
}

TEST(PanelApi, TheJogMovesAnIdleMachineAndStopsWhenTheStickIsLetGo) {
  PanelRig rig(1.0);
  rig.take_control();
  const double x0 = rig.status()["position_mm"][0].get<double>();
  // Hold the stick right for a while, as a held key does (a request every 100 ms).
  for (int i = 0; i < 12; ++i) {
    ASSERT_EQ(rig.post("/api/jog", {{"x", 1.0}, {"y", 0.0}}).status, 200);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_EQ(rig.status()["activity"], "jogging");
  // Let go: the dead man centres the stick, and the jog session ends by itself.
  ASSERT_TRUE(rig.wait_idle(30));
  const json s = rig.status();
  EXPECT_GT(s["position_mm"][0].get<double>(), x0 + 1.0);
  EXPECT_TRUE(s["faults"].empty()) << s.dump();
  EXPECT_EQ(rig.post("/api/jog", {{"x", 0.0}, {"y", 0.0}}).status, 200) << "a centred stick starts nothing";
  EXPECT_EQ(rig.status()["activity"], "idle");
}

// Sheet alignment as the page does it: jog to a point on the edge and take the position, jog
// along the edge and take the second; the job loaded with them has its zero at the first and
// turns by the edge's angle.
TEST(PanelApi, AJobIsAlignedToTwoEdgePointsTakenByJogging) {
  PanelRig rig(1.0);
  rig.take_control();
  const auto jog_and_take = [&](double x, double y) {
    for (int i = 0; i < 12; ++i) {
      EXPECT_EQ(rig.post("/api/jog", {{"x", x}, {"y", y}}).status, 200);
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    EXPECT_TRUE(rig.wait_idle(30));
    const json p = rig.status()["position_mm"];
    return Eigen::Vector2d(p[0].get<double>(), p[1].get<double>());
  };
  const Eigen::Vector2d first = jog_and_take(1.0, 0.0), second = jog_and_take(1.0, 0.5);
  ASSERT_GT((second - first).norm(), 20.0);
  const json r = rig.load({{"program", kTriangle}, {"align", {{first.x(), first.y()}, {second.x(), second.y()}}}});
  EXPECT_EQ(r["origin_from"], "sheet alignment") << r.dump();
  EXPECT_NEAR(r["origin_mm"][0].get<double>(), first.x(), 1e-9);
  EXPECT_NEAR(r["origin_mm"][1].get<double>(), first.y(), 1e-9);
  const double angle = std::atan2(second.y() - first.y(), second.x() - first.x()) * 180.0 / M_PI;
  EXPECT_GT(angle, 5.0);
  EXPECT_NEAR(r["rotation_deg"].get<double>(), angle, 1e-9);
}

TEST(PanelApi, RunFromALineRunsTheTailOfTheJob) {
  PanelRig rig(0);
  rig.take_control();
  rig.load({{"program", kTriangle}});
  const HttpResponse too_far = rig.post("/api/run", {{"from_line", 400}});
  EXPECT_EQ(too_far.status, 400);
  EXPECT_NE(too_far.body.find("triangle_45.ngc:400"), std::string::npos) << too_far.body;
  ASSERT_EQ(rig.post("/api/run", {{"from_line", 11}}).status, 200);  // the vertical leg
  ASSERT_TRUE(rig.wait_for([&](const json&) { return rig.panel->runs_finished() == 1; }));
  const json r = json::parse(rig.get("/api/report").body);
  EXPECT_EQ(r["status"], "done") << r.dump();
  ASSERT_EQ(r["cuts"].size(), 1u);
  EXPECT_EQ(r["cuts"][0]["source_line"], 11) << "the cut starts at the line asked for";
}

// Framing: the loaded job's outline traced with the torch off, answered with the outline and
// reported as a run; the job then runs from where the frame left the machine (its start).
TEST(PanelApi, TheFrameTracesTheLoadedJobsOutlineWithTheTorchOff) {
  PanelRig rig(0);
  rig.take_control();
  EXPECT_EQ(rig.post("/api/frame", json::object()).status, 409) << "no job is loaded";
  rig.load({{"program", kTriangle}});
  const HttpResponse slow = rig.post("/api/frame", {{"feed", -1}});
  EXPECT_EQ(slow.status, 400);
  EXPECT_NE(slow.body.find("feed"), std::string::npos) << slow.body;
  EXPECT_EQ(rig.post("/api/frame", {{"margin", 5000}}).status, 400);
  const HttpResponse f = rig.post("/api/frame", {{"feed", 60}, {"margin", 2}});
  ASSERT_EQ(f.status, 200) << f.body;
  const json frame = json::parse(f.body)["frame"];
  EXPECT_EQ(frame["x_mm"], json({198.0, 302.0}));
  EXPECT_EQ(frame["y_mm"], json({198.0, 302.0}));
  EXPECT_EQ(frame["feed_mm_per_s"], 60.0);
  ASSERT_TRUE(rig.wait_for([&](const json&) { return rig.panel->runs_finished() == 1; }));
  const json r = json::parse(rig.get("/api/report").body);
  EXPECT_EQ(r["status"], "done") << r.dump();
  EXPECT_EQ(r["frame"], frame);
  EXPECT_TRUE(r["cuts"].empty());
  EXPECT_EQ(r["torch_on_s"], 0.0);
  // Again with the laser pointer: the axes trace the outline less its offset (the gantry's
  // laser block), the same outline for the dot.
  const HttpResponse lf = rig.post("/api/frame", {{"feed", 60}, {"margin", 2}, {"laser", true}});
  ASSERT_EQ(lf.status, 200) << lf.body;
  const json laser_frame = json::parse(lf.body)["frame"];
  EXPECT_EQ(laser_frame["pointer_offset_mm"], json({60.0, 0.0}));
  EXPECT_EQ(laser_frame["x_mm"], frame["x_mm"]);
  ASSERT_TRUE(rig.wait_for([&](const json&) { return rig.panel->runs_finished() == 2; }));
  const json lr = json::parse(rig.get("/api/report").body);
  EXPECT_EQ(lr["status"], "done") << lr.dump();
  EXPECT_EQ(lr["frame"], laser_frame);
  EXPECT_EQ(lr["torch_on_s"], 0.0);
  ASSERT_EQ(rig.post("/api/run", json::object()).status, 200);
  ASSERT_TRUE(rig.wait_for([&](const json&) { return rig.panel->runs_finished() == 3; }));
  const json cut = json::parse(rig.get("/api/report").body);
  EXPECT_EQ(cut["status"], "done") << cut.dump();
  EXPECT_EQ(cut["cuts"].size(), 1u);
  EXPECT_FALSE(cut.contains("frame"));
}

// A job takes a QtPlasmaC material file (a path, or its text from the page) and the material in
// force, as `run --materials --material`; the run's cuts are cut in it, and a bad file is
// answered with 400 naming its line.
TEST(PanelApi, AJobTakesAMaterialFileAndTheMaterialInForce) {
  PanelRig rig(0);
  rig.take_control();
  const std::string text = "[MATERIAL_NUMBER_7]\nNAME = Thin\nKERF_WIDTH = 1.1\nPIERCE_HEIGHT = 3\nPIERCE_DELAY = 0.1\n"
                           "CUT_HEIGHT = 1\nCUT_SPEED = 2100\n";
  const HttpResponse bad = rig.post("/api/job", {{"program", kTriangle}, {"materials", "[MATERIAL_NUMBER_7]\nCUT_SPEED = x\n"}});
  EXPECT_EQ(bad.status, 400);
  EXPECT_NE(bad.body.find("materials.cfg:2"), std::string::npos) << bad.body;
  const HttpResponse missing = rig.post("/api/job", {{"program", kTriangle}, {"materials", text}, {"material", 3}});
  EXPECT_EQ(missing.status, 400);
  EXPECT_NE(missing.body.find("material 3 is not in"), std::string::npos) << missing.body;
  rig.load({{"program", kTriangle}, {"materials", text}, {"material", 7}});
  ASSERT_EQ(rig.post("/api/run", json::object()).status, 200);
  ASSERT_TRUE(rig.wait_for([&](const json&) { return rig.panel->runs_finished() == 1; }));
  const json r = json::parse(rig.get("/api/report").body);
  EXPECT_EQ(r["status"], "done") << r.dump();
  ASSERT_EQ(r["materials"].size(), 1u) << r.dump();
  EXPECT_EQ(r["materials"][0]["number"], 7);
  EXPECT_DOUBLE_EQ(r["materials"][0]["cut_feed_mm_per_min"].get<double>(), 2100.0);
  ASSERT_GT(r["cuts"].size(), 0u);
  for (const json& cut : r["cuts"]) EXPECT_EQ(cut["material"], 0) << cut.dump();
  // The bundled file by path; the same run again uses it too.
  rig.load({{"program", kTriangle}, {"materials", "datasets/materials/thermal_gantry_material.cfg"}, {"material", 2}});
  ASSERT_EQ(rig.post("/api/run", json::object()).status, 200);
  ASSERT_TRUE(rig.wait_for([&](const json&) { return rig.panel->runs_finished() == 2; }));
  ASSERT_EQ(rig.post("/api/run", json::object()).status, 200);
  ASSERT_TRUE(rig.wait_for([&](const json&) { return rig.panel->runs_finished() == 3; }));
  const json again = json::parse(rig.get("/api/report").body);
  EXPECT_EQ(again["status"], "done") << again.dump();
  ASSERT_EQ(again["materials"].size(), 1u) << again.dump();
  EXPECT_EQ(again["materials"][0]["number"], 2);
}

TEST(PanelApi, AHybridSessionIsSteeredFromThePanelAndFinishes) {
  PanelRig rig(8.0);
  rig.take_control();
  const json g = {{"profile", "datasets/profiles/paper_triangle.dxf"},
                  {"side", "outside"},
                  {"tool_radius_mm", 5},
                  {"tolerance_mm", 4},
                  {"feed_mm_per_s", 60},
                  {"finish", true}};
  ASSERT_EQ(rig.post("/api/guard", g).status, 200) << rig.post("/api/guard", g).body;
  ASSERT_TRUE(rig.wait_for(
      [](const json& s) { return s.contains("guard") && s["guard"]["phase"] == "roughing" && s["guard"]["t_s"].get<double>() > 0; }));
  const json drawing = json::parse(rig.get("/api/guard").body);
  EXPECT_FALSE(drawing["profile"].empty());
  EXPECT_FALSE(drawing["boundary"].empty());
  const double d0 = rig.status()["guard"]["distance_mm"].get<double>();
  EXPECT_GT(d0, 0.0) << "the session starts outside the prohibited region";
  // Along under the triangle's bottom edge (y = 0; the session starts below and left of it),
  // then straight up at it until the guard brings the table to rest against the boundary.
  const auto push = [&](double x, double y, const std::function<bool(const json&)>& until) {
    for (int i = 0; i < 100; ++i) {
      EXPECT_EQ(rig.post("/api/jog", {{"x", x}, {"y", y}}).status, 200);
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      const json s = rig.status()["guard"];
      if (until(s)) return s;
    }
    return json();
  };
  const json under = push(1.0, 0.0, [](const json& g) { return g["position_mm"][0].get<double>() > 40.0; });
  ASSERT_FALSE(under.is_null()) << "the stick moved the table";
  EXPECT_LT(under["position_mm"][1].get<double>(), -5.0) << "clear of the boundary below the edge";
  bool held = false;
  double closest = d0;
  for (int i = 0; i < 100 && !held; ++i) {
    ASSERT_EQ(rig.post("/api/jog", {{"x", 0.0}, {"y", 1.0}}).status, 200);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const json s = rig.status()["guard"];
    closest = std::min(closest, s["distance_mm"].get<double>());
    held = s["holding"] == true;
  }
  EXPECT_TRUE(held) << "the guard held the table at the tolerance band";
  EXPECT_GE(closest, -1e-3) << "never into the prohibited region";
  ASSERT_EQ(rig.post("/api/resume").status, 200);  // cycle start: the end of the manual part
  ASSERT_TRUE(rig.wait_idle(180));
  const json done = json::parse(rig.get("/api/guard").body);
  ASSERT_TRUE(done.contains("result")) << done.dump().substr(0, 400);
  EXPECT_EQ(done["result"]["invasions"], 0);
  ASSERT_FALSE(done["finish_paths"].empty());
  EXPECT_EQ(done["finish_paths"].back()["completed"], true);
}

TEST(PanelApi, HistoryIsReadOnly) {
  PanelRig rig(0);
  const json h = json::parse(rig.get("/api/history").body);
  EXPECT_TRUE(h["calibrations"].empty());
  EXPECT_TRUE(h["tunings"].empty());
  EXPECT_FALSE(std::filesystem::exists(h["store"].get<std::string>())) << "reading the history creates no store";
}

// The L bracket (datasets/parts/bracket_l.ngc) through the API, with an origin, held and resumed mid-cut: the same contour
// error as `machplan run` (the same pipeline, machine and seed; a hold and its re-pierce are the
// only difference), and GET /api/report gives it.
TEST(PanelApi, TheBracketHeldAndResumedMidCutMatchesMachplanRun) {
  motion::RunOptions o;
  o.session.machine = "thermal_gantry";
  o.session.executor.record_trace = false;
  o.origin_mm = Eigen::Vector2d(150, 120);
  const motion::RunOutcome cli = motion::run_program(test::source_path("datasets/parts/bracket_l.ngc"), o);
  ASSERT_TRUE(cli.summary.done());

  PanelRig rig(4.0);
  rig.take_control();
  rig.load({{"program", test::source_path("datasets/parts/bracket_l.ngc")}, {"origin", {150, 120}}});
  ASSERT_EQ(rig.post("/api/run").status, 200);
  // Mid-cut: the torch burns on the outline (the last cut, lines 40 on). A run that faults on
  // the way ends the wait at once.
  json seen;
  ASSERT_TRUE(rig.wait_for(
      [&](const json& s) {
        seen = s;
        return s["state"] == "faulted" ||
               (s["torch"]["arc_ok"] == true && s["line"].get<int>() >= 40 && s["feed_mm_per_s"].get<double>() > 10);
      },
      300))
      << rig.status().dump();
  ASSERT_NE(seen["state"], "faulted") << seen.dump();
  ASSERT_EQ(rig.post("/api/hold").status, 200);
  ASSERT_TRUE(rig.wait_for([](const json& s) { return s["state"] == "held"; }));
  ASSERT_EQ(rig.post("/api/resume").status, 200);
  ASSERT_TRUE(rig.wait_for([&](const json&) { return rig.panel->runs_finished() == 1; }, 300));
  const HttpResponse rep = rig.get("/api/report");
  ASSERT_EQ(rep.status, 200);
  const json r = json::parse(rep.body);
  ASSERT_EQ(r["status"], "done") << r.value("faults", json::array()).dump() << " " << r.value("summary", json::object()).dump();
  ASSERT_EQ(r["holds"].size(), 1u);
  EXPECT_EQ(r["holds"][0]["in_cut"], true);
  EXPECT_EQ(r["cuts"].size(), cli.result.cuts.size());
  const double max_cli = cli.result.max_contour_error_mm(), rms_cli = cli.rms_contour_error_mm;
  const double max_panel = r["max_contour_error_mm"].get<double>(), rms_panel = r["rms_contour_error_mm"].get<double>();
  std::printf("bracket: max contour error %.4f mm (machplan run %.4f), rms %.4f mm (%.4f)\n", max_panel, max_cli, rms_panel, rms_cli);
  EXPECT_NEAR(max_panel, max_cli, 0.02);
  EXPECT_NEAR(rms_panel, rms_cli, 0.25 * rms_cli);
}

// Every job the panel runs joins the machine's statistics in its store, with the figures of its
// own report; the consumables button restarts the counters since the change, not the lifetime.
TEST(PanelApi, AJobIsRecordedAndTheConsumablesButtonRestartsItsCounters) {
  PanelRig rig(0);
  const json before = json::parse(rig.get("/api/statistics").body);
  EXPECT_EQ(before["lifetime"]["jobs"], 0);
  EXPECT_EQ(rig.post("/api/consumables").status, 409) << "changing consumables needs control";
  rig.take_control();
  rig.load({{"program", kTriangle}});
  ASSERT_EQ(rig.post("/api/run").status, 200);
  ASSERT_TRUE(rig.wait_for([&](const json&) { return rig.panel->runs_finished() == 1; }));
  const json r = json::parse(rig.get("/api/report").body);
  const json s = json::parse(rig.get("/api/statistics").body);
  ASSERT_EQ(s["jobs"].size(), 1u) << s.dump();
  EXPECT_EQ(s["jobs"][0]["status"], r["status"]);
  EXPECT_EQ(s["jobs"][0]["figures"]["pierces"].get<std::size_t>(), r["cuts"].size());
  EXPECT_GT(s["lifetime"]["pierces"].get<int>(), 0);
  EXPECT_DOUBLE_EQ(s["lifetime"]["arc_on_s"].get<double>(), r["torch_on_s"].get<double>());
  EXPECT_EQ(rig.post("/api/consumables", {{"who", 5}}).status, 400);
  const HttpResponse changed = rig.post("/api/consumables", {{"who", "ana"}});
  ASSERT_EQ(changed.status, 200) << changed.body;
  const json after = json::parse(changed.body)["statistics"];
  EXPECT_EQ(after["since_change"]["jobs"], 0);
  EXPECT_EQ(after["since_change"]["pierces"], 0);
  EXPECT_EQ(after["lifetime"]["pierces"], s["lifetime"]["pierces"]);
  EXPECT_EQ(after["last_change"]["who"], "ana");
}

}  // namespace
}  // namespace machplan
