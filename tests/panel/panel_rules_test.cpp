// `machplan run`'s rules between options, met by the panel as by the command line: they live in
// the options' validate() (solvers/session/machine_session.h, models/backends/backend_factory.h),
// so the panel's options (what `serve` and a library caller build) are refused with the field
// message the command line prints under its flag, and a panel in a paper mode refuses over HTTP
// what a paper-mode run refuses in its operator timeline, with the same rule.
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/common/error.h"
#include "engine/hardware/operator_events.h"
#include "models/backends/backend_factory.h"
#include "solvers/session/machine_session.h"
#include "tests/panel/panel_test_rig.h"
#include "tests/support/cli_run.h"

namespace machplan {
namespace {

using nlohmann::json;

const char* const kTriangleProgram = "datasets/parts/triangle_45.ngc";

// The panel's refusal of `po`: the field it names and the message.
InputError panel_refusal(panel::PanelOptions po) {
  po.pace = false;
  try {
    panel::Panel p(po);
  } catch (const InputError& e) {
    return e;
  }
  return InputError("<accepted>", 0, "");
}

struct Combination {
  std::string what;
  std::vector<std::string> run_flags;  // after `run PROGRAM --machine thermal_gantry`
  std::string flag;                    // the flag the command line names
  std::function<void(panel::PanelOptions&)> set;
};

TEST(PanelRules, EveryForbiddenCombinationOfRunIsRefusedByThePanelWithTheCommandLinesMessage) {
  const test::Cli cli;
  const std::string hold = cli.write("hold.csv", "t_s,event,value\n5.0,hold,\n6.0,start,\n");
  const std::string stop = cli.write("stop.csv", "t_s,event,value\n5.0,stop,\n");
  std::vector<Combination> cases = {
      {"a vector length in planned mode", {"--blu", "5"}, "--blu", [](panel::PanelOptions& po) { po.session.executor.blu_mm = 5; }},
      {"a calibration factor in planned mode", {"--calibration", "1.5"}, "--calibration",
       [](panel::PanelOptions& po) { po.session.executor.calibration_factor = 1.5; }},
      {"the active calibration in a paper mode without its feed", {"--mode", "paper-open", "--calibration", "active"}, "--feed",
       [](panel::PanelOptions& po) {
         po.session.executor.mode = executor::Mode::paper_open;
         po.session.active_calibration = true;
       }},
      {"a feed hold in a paper mode", {"--mode", "paper-open", "--operator-events", hold}, "--operator-events",
       [&](panel::PanelOptions& po) {
         po.session.executor.mode = executor::Mode::paper_open;
         po.session.backend.sim.operator_events = hardware::read_operator_events(hold).states;
       }},
  };
  // What only the simulator does, on every other backend this build has.
  for (const std::string& name : backends::backend_names()) {
    if (name == "sim") continue;
    cases.push_back({"an injected fault on " + name, {"--backend", name, "--inject", "estop@1.5"}, "--inject",
                     [name](panel::PanelOptions& po) {
                       po.session.backend.name = name;
                       po.session.backend.sim.faults.push_back({sim::FaultInjection::Kind::estop, 1.5});
                     }});
    cases.push_back({"an operator timeline on " + name, {"--backend", name, "--operator-events", stop}, "--operator-events",
                     [name, stop](panel::PanelOptions& po) {
                       po.session.backend.name = name;
                       po.session.backend.sim.operator_events = hardware::read_operator_events(stop).states;
                     }});
    cases.push_back({"a warped sheet on " + name, {"--backend", name, "--sheet-warp", "2,300"}, "--sheet-warp",
                     [name](panel::PanelOptions& po) {
                       po.session.backend.name = name;
                       po.session.backend.sim.sheet_warp_mm = std::make_pair(2.0, 300.0);
                     }});
  }
  for (const Combination& c : cases) {
    SCOPED_TRACE(c.what);
    std::vector<std::string> args = {"run", kTriangleProgram, "--machine", "thermal_gantry"};
    args.insert(args.end(), c.run_flags.begin(), c.run_flags.end());
    const test::CliResult r = cli.run(args);
    EXPECT_EQ(r.code, 2) << r.err;
    panel::PanelOptions po;
    po.session.machine = "thermal_gantry";
    c.set(po);
    const InputError e = panel_refusal(po);
    ASSERT_TRUE(e.is_field()) << e.what();
    EXPECT_EQ(e.where().rfind("session.", 0), 0u) << "the panel's field: " << e.where();
    EXPECT_EQ(r.err, c.flag + ": " + e.message() + "\n") << "the panel: " << e.what();
    EXPECT_EQ(e.message().find("--"), std::string::npos) << "the library names no flag: " << e.message();
  }
}

// A panel in a paper mode: what a paper-mode run's operator timeline may not hold, its buttons
// may not ask. The refusal is the command line's rule, word for word.
TEST(PanelRules, APaperModePanelRefusesHoldsOverridesAndRecoveryAsTheCommandLineDoes) {
  const test::PanelRig rig(0, "thermal_gantry",
                           [](panel::PanelOptions& po) { po.session.executor.mode = executor::Mode::paper_open; });
  rig.take_control();
  const test::Cli cli;
  const struct {
    const char* event;  // a row of the operator timeline, at 5 s
    const char* route;
    json body;
  } cases[] = {
      {"hold,", "/api/hold", json::object()},
      {"start,", "/api/resume", json::object()},
      {"feed_override,50", "/api/override", {{"feed", 50}}},
      {"rapid_override,25", "/api/override", {{"rapid", 25}}},
      {"paused_motion,-5", "/api/paused_motion", {{"mm", -5}}},
      {"paused_motion_speed,-0.5", "/api/paused_motion", {{"speed", -0.5}}},
  };
  const std::string rule = session::kPaperModesLack;
  for (const auto& c : cases) {
    SCOPED_TRACE(c.event);
    const std::string events = cli.write("events.csv", std::string("t_s,event,value\n5.0,") + c.event + "\n");
    const test::CliResult r =
        cli.run({"run", kTriangleProgram, "--machine", "thermal_gantry", "--mode", "paper-open", "--operator-events", events});
    ASSERT_EQ(r.code, 2) << r.err;
    // "--operator-events: a feed hold at 5 s: RULE": what is asked, when, and the rule.
    const std::string head = "--operator-events: ", tail = " at 5 s: " + rule + "\n";
    ASSERT_EQ(r.err.rfind(head, 0), 0u) << r.err;
    ASSERT_GT(r.err.size(), head.size() + tail.size());
    ASSERT_EQ(r.err.substr(r.err.size() - tail.size()), tail) << r.err;
    const std::string asked = r.err.substr(head.size(), r.err.size() - head.size() - tail.size());
    const test::HttpResponse a = rig.post(c.route, c.body);
    EXPECT_EQ(a.status, 400) << a.body;
    EXPECT_EQ(json::parse(a.body, nullptr, false).value("error", ""), asked + ": " + rule) << a.body;
  }
  // Stop, the THC switch and the E-stop are the paper modes' too.
  EXPECT_EQ(rig.post("/api/thc", {{"enabled", false}}).status, 200);
  EXPECT_EQ(rig.post("/api/stop").status, 200);
  EXPECT_EQ(rig.post("/api/override", {{"feed", 100}, {"rapid", 100}}).status, 200) << "100 % changes nothing";
  EXPECT_EQ(rig.post("/api/estop").status, 200);
  EXPECT_EQ(rig.status()["estop"], true);
}

}  // namespace
}  // namespace machplan
