// The panel's live stream against the executor's tick: does a crowd of WebSocket viewers
// show in the tick's tail?
//
//   BM_PanelTick/viewers:V/round:R   the L bracket (datasets/parts/bracket_l.ngc, 33.6 s of
//                        machine time) run on the simulated gantry through the panel's machine
//                        session, paced at 1 ms per tick on the wall clock, while `machplan
//                        serve`'s server (cli/panel/server.h) streams the session's live state
//                        at 50 Hz to V WebSocket viewers on loopback, each a thread of this
//                        process reading every frame. Each tick (simulator exchange included,
//                        the pacing sleep not) is timed on the steady clock: 50th, 99th,
//                        99.9th percentile and maximum, in microseconds. frames_per_viewer:
//                        what each viewer received in the run (50 Hz x 33.6 s = 1680 when none
//                        is skipped).
//
// The rounds alternate 0 and 50 viewers, so that the load the machine carries from elsewhere
// falls on both alike. The bench runs the tick on its own thread, as the panel's runner does;
// the tick publishes its LiveState without a lock and the server's threads only read it.
//
// BM_SlowClients/sockets:S/seconds:T   `serve`'s server (default limits) on the simulated gantry
//                        while S sockets each send one more byte of a request head that never
//                        ends every second, and reconnect when the server closes them, for T
//                        seconds. Meanwhile a client polls GET /api/status ten times a second
//                        and presses the E-stop (then reset) every 2 s: status_p50_ms,
//                        status_p99_ms, status_p99.9_ms, status_max_ms and requests (as the
//                        tick's percentiles are counted), failed (answers other than 200),
//                        estop_max_ms (request to answer: the E-stop is applied before it is
//                        answered), reconnects and evicted (slow heads closed to make room).
//
// fifo:1 runs the tick's thread SCHED_FIFO (priority 70), as machplan runs the executor's
// thread on a real machine (the HAL backend, engine/hardware/hal_backend.h); fifo:0 leaves it
// to the ordinary scheduler. The viewers here are threads of this process on the same two cores
// (a browser would run on its own machine), so with fifo:0 the tick competes with 50 readers
// and the server for the CPU: that is the scheduler's doing, not the panel's. The run fails
// when SCHED_FIFO is not allowed (not root, no CAP_SYS_NICE).
#include <poll.h>
#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <benchmark/benchmark.h>

#include "bench/tick_percentiles.h"
#include "cli/panel/panel.h"
#include "cli/panel/server.h"
#include "solvers/motion/run.h"
#include "tests/support/http_client.h"

namespace machplan {
namespace {

using Clock = std::chrono::steady_clock;

struct Crowd {
  std::vector<std::unique_ptr<test::WsClient>> clients;
  std::vector<std::thread> readers;
  std::atomic<long> frames{0};
  std::atomic<bool> go{true};

  Crowd(int port, const std::string& token, int n) {
    for (int i = 0; i < n; ++i) {
      clients.push_back(std::make_unique<test::WsClient>(port, "/api/live", test::Headers{{"Authorization", "Bearer " + token}}, 2.0));
      if (!clients.back()->ok()) throw std::runtime_error("viewer refused: " + clients.back()->response());
    }
    for (auto& c : clients)
      readers.emplace_back([this, w = c.get()] {
        while (go.load()) {
          if (w->next_text().empty()) continue;  // a timeout: look at `go` again
          ++frames;
        }
      });
  }
  ~Crowd() {
    go = false;
    for (auto& r : readers) r.join();  // each read times out within 2 s
  }
};

// The calling thread SCHED_FIFO at `priority` for its lifetime, then as it was.
class FifoScope {
 public:
  explicit FifoScope(int priority) {
    pthread_getschedparam(pthread_self(), &policy_, &param_);
    const sched_param p{priority};
    ok_ = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) == 0;
  }
  ~FifoScope() {
    if (ok_) pthread_setschedparam(pthread_self(), policy_, &param_);
  }
  bool ok() const { return ok_; }

 private:
  int policy_ = SCHED_OTHER;
  sched_param param_{};
  bool ok_ = false;
};

void BM_PanelTick(benchmark::State& state) {
  const int viewers = static_cast<int>(state.range(0));
  const bool fifo = state.range(2) != 0;
  panel::PanelOptions po;
  po.session.machine = "thermal_gantry";
  po.pace = false;  // this loop paces the ticks, outside them
  panel::Panel panel(po);
  panel::ServerOptions so;
  so.port = 0;
  panel::Server server(panel, so);

  motion::RunOptions ro;
  ro.session = po.session;
  const motion::PlannedRun plan = motion::plan_program(std::string(MACHPLAN_SOURCE_DIR) + "/datasets/parts/bracket_l.ngc", ro,
                                                       panel.session().machine(), {});
  std::vector<double> us;
  us.reserve(40000);
  double frames_per_viewer = 0;
  for (auto _ : state) {
    us.clear();
    const Crowd crowd(server.port(), server.token(), viewers);
    session::MachineSession::RunHooks hooks;
    hooks.expected_s = plan.expected_s();
    const std::unique_ptr<executor::Session> s = panel.session().start(plan.job, plan.trajectories, hooks);
    std::optional<FifoScope> rt;
    if (fifo && !rt.emplace(70).ok()) {
      state.SkipWithError("SCHED_FIFO is not allowed here (run as root, or with CAP_SYS_NICE)");
      break;
    }
    auto next = Clock::now();
    for (bool more = true; more;) {
      const auto t0 = Clock::now();
      more = s->tick();
      const auto t1 = Clock::now();
      us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
      next += std::chrono::milliseconds(1);
      std::this_thread::sleep_until(next);
    }
    rt.reset();
    const executor::ExecutionResult r = s->finish();
    if (!r.faults.empty()) state.SkipWithError(r.faults.front().message.c_str());
    frames_per_viewer = viewers ? static_cast<double>(crowd.frames.load()) / viewers : 0.0;
  }
  bench::report_tick_percentiles(state, us);
  state.counters["frames_per_viewer"] = frames_per_viewer;
}
// S loopback sockets each sending one byte of an endless head a second; a socket the server
// closes is opened again at once.
struct SlowHeads {
  std::vector<std::unique_ptr<test::StalledClient>> sockets;
  std::atomic<bool> go{true};
  std::atomic<long> reconnects{0};
  std::thread driver;
  int port;

  SlowHeads(int port_, int n) : port(port_) {
    for (int i = 0; i < n; ++i) sockets.push_back(open());
    driver = std::thread([this] {
      while (go.load()) {
        for (auto& s : sockets) {
          if (!s->send("a") || s->closed_within(0.0)) {
            s = open();
            ++reconnects;
          }
        }
        std::this_thread::sleep_for(std::chrono::seconds(1));
      }
    });
  }
  std::unique_ptr<test::StalledClient> open() const {
    return std::make_unique<test::StalledClient>(port, "GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ");
  }
  ~SlowHeads() {
    go = false;
    driver.join();
  }
};

void BM_SlowClients(benchmark::State& state) {
  const int sockets = static_cast<int>(state.range(0));
  const double seconds = static_cast<double>(state.range(1));
  panel::PanelOptions po;
  po.session.machine = "thermal_gantry";
  panel::Panel panel(po);
  panel::ServerOptions so;
  so.port = 0;
  panel::Server server(panel, so);
  const test::Headers auth{{"Authorization", "Bearer " + server.token()}, {"X-Machplan-Client", "bench-client"}};
  if (test::http(server.port(), "POST", "/api/control", auth, "{}").status != 200) throw std::runtime_error("control refused");
  std::vector<double> status_ms;
  double estop_max_ms = 0;
  long failed = 0;
  long reconnects = 0;
  for (auto _ : state) {
    SlowHeads slow(server.port(), sockets);
    const auto end = Clock::now() + std::chrono::duration<double>(seconds);
    auto next_estop = Clock::now() + std::chrono::seconds(2);
    while (Clock::now() < end) {
      const auto t0 = Clock::now();
      if (test::http(server.port(), "GET", "/api/status", auth, {}, 10.0).status != 200) ++failed;
      status_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      if (Clock::now() >= next_estop) {
        next_estop += std::chrono::seconds(2);
        const auto e0 = Clock::now();
        if (test::http(server.port(), "POST", "/api/estop", auth, "{}", 10.0).status != 200) ++failed;
        estop_max_ms = std::max(estop_max_ms, std::chrono::duration<double, std::milli>(Clock::now() - e0).count());
        if (test::http(server.port(), "POST", "/api/reset", auth, "{}", 10.0).status != 200) ++failed;
      }
      std::this_thread::sleep_until(t0 + std::chrono::milliseconds(100));
    }
    reconnects = slow.reconnects.load();
  }
  bench::report_percentiles(state, status_ms, "status_", "_ms", "requests");
  state.counters["failed"] = static_cast<double>(failed);
  state.counters["estop_max_ms"] = estop_max_ms;
  state.counters["reconnects"] = static_cast<double>(reconnects);
  state.counters["evicted"] = static_cast<double>(server.counters().evicted);
}

BENCHMARK(BM_SlowClients)->ArgNames({"sockets", "seconds"})->Args({200, 60})->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

BENCHMARK(BM_PanelTick)
    ->ArgNames({"viewers", "round", "fifo"})
    ->Apply([](benchmark::internal::Benchmark* b) {  // rounds alternating 0 and 50 viewers, each scheduling
      for (int fifo : {0, 1})
        for (int round = 1; round <= 3; ++round) b->Args({0, round, fifo})->Args({50, round, fifo});
    })
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();

}  // namespace
}  // namespace machplan

BENCHMARK_MAIN();
