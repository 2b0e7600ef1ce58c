// A panel (cli/panel) with its server on an ephemeral loopback port, for the panel's tests:
// requests go through real HTTP and WebSocket connections. Every wait is bounded; a verdict
// waits for a state, never for a time.
#pragma once

#include <chrono>
#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli/panel/panel.h"
#include "cli/panel/server.h"
#include "tests/support/http_client.h"
#include "tests/support/temp_dir.h"

namespace machplan::test {

struct PanelRig {
  TempDir dir;
  std::unique_ptr<panel::Panel> panel;
  std::unique_ptr<panel::Server> server;
  int port = 0;
  std::string token;

  // `speed`: simulated seconds per wall second (0: unpaced, as fast as it goes). `adjust`
  // changes the panel's options last (a paper mode, an injected fault), `adjust_server` the
  // server's (its limits).
  explicit PanelRig(double speed = 8.0, const std::string& machine = "thermal_gantry",
                    const std::function<void(panel::PanelOptions&)>& adjust = {},
                    const std::function<void(panel::ServerOptions&)>& adjust_server = {}) {
    panel::PanelOptions po;
    po.session.machine = machine;
    po.pace = speed > 0;
    po.sim_speed = speed > 0 ? speed : 1.0;
    // The simulator's watchdog counts machine periods; paced at `speed` times the wall clock,
    // its 50 would trip after 50 / speed ms of a stalled test process (6 ms at 8x, which a
    // loaded two-core CI machine gives now and then). The rig keeps 50 ms of wall time, as a
    // real machine's watchdog has.
    po.session.backend.sim.watchdog_periods = static_cast<int>(std::ceil(50.0 * std::max(1.0, po.sim_speed)));
    po.store_path = (dir.path() / "store.db").string();
    if (adjust) adjust(po);
    panel = std::make_unique<panel::Panel>(po);
    panel::ServerOptions so;
    so.port = 0;
    if (adjust_server) adjust_server(so);
    server = std::make_unique<panel::Server>(*panel, so);
    port = server->port();
    token = server->token();
  }
  ~PanelRig() {
    server.reset();
    panel.reset();
  }

  Headers auth(const std::string& client = "client-one") const {
    return {{"Authorization", "Bearer " + token}, {"X-Machplan-Client", client}};
  }
  HttpResponse get(const std::string& path, const std::string& client = "client-one") const {
    return http(port, "GET", path, auth(client));
  }
  HttpResponse post(const std::string& path, const nlohmann::json& body = nlohmann::json::object(),
                    const std::string& client = "client-one") const {
    return http(port, "POST", path, auth(client), body.dump());
  }
  nlohmann::json status() const {
    const HttpResponse r = get("/api/status");
    EXPECT_EQ(r.status, 200) << r.body;
    return nlohmann::json::parse(r.body, nullptr, false);
  }
  void take_control(const std::string& client = "client-one") const {
    const HttpResponse r = post("/api/control", {{"take", true}}, client);
    ASSERT_EQ(r.status, 200) << r.body;
  }
  // Polls the status until `pred` holds (true) or `timeout_s` of wall time passed (false).
  bool wait_for(const std::function<bool(const nlohmann::json&)>& pred, double timeout_s = 120.0) const {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end) {
      const nlohmann::json s = status();
      if (s.is_object() && pred(s)) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }
  bool wait_idle(double timeout_s = 120.0) const {
    return wait_for([](const nlohmann::json& s) { return s["activity"] == "idle"; }, timeout_s);
  }
  nlohmann::json load(const nlohmann::json& body) const {
    const HttpResponse r = post("/api/job", body);
    EXPECT_EQ(r.status, 200) << r.body;
    return nlohmann::json::parse(r.body, nullptr, false);
  }
};

inline std::string source_path(const std::string& rel) { return std::string(MACHPLAN_SOURCE_DIR) + "/" + rel; }

}  // namespace machplan::test
