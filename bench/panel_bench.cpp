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
// fifo:1 runs the tick's thread SCHED_FIFO (priority 70), as machplan runs the executor's
// thread on a real machine (the HAL backend, engine/hardware/hal_backend.h); fifo:0 leaves it
// to the ordinary scheduler. The viewers here are threads of this process on the same two cores
// (a browser would run on its own machine), so with fifo:0 the tick competes with 50 readers
// and the server for the CPU: that is the scheduler's doing, not the panel's. The run fails
// when SCHED_FIFO is not allowed (not root, no CAP_SYS_NICE).
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
