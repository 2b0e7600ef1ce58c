#include "engine/hardware/hal_backend.h"

#include <pthread.h>
#include <sched.h>
#include <signal.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/hardware/hal/exchange_block.h"

// LinuxCNC's headers are C; the userspace API (ULAPI) is what a program outside the servo
// thread may call.
extern "C" {
#include <hal.h>
#include <rtapi.h>
// Exported by liblinuxcnchal but declared for real-time code only: HAL's messages to the
// program go through it.
void rtapi_set_msg_handler(rtapi_msg_handler_t handler);
}

namespace machplan::hardware {

namespace {

// Errors name the backend option (the command line's --backend).
[[noreturn]] void fail(const std::string& what) { throw InputError::field("backend", "hal: " + what); }

std::int64_t now_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

void sleep_until_ns(std::int64_t t) {
  timespec ts{static_cast<time_t>(t / 1000000000), static_cast<long>(t % 1000000000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

// HAL's own messages (hal_init's complaints) are kept for our error text instead of going to
// stderr.
std::mutex g_msg_mutex;
std::string g_msg;
void keep_message(msg_level_t level, const char* format, va_list ap) {
  if (level > RTAPI_MSG_ERR) return;
  std::string line(512, '\0');  // a string, not a local array: g++ 12 takes the array for a dangling pointer
  const int n = std::vsnprintf(line.data(), line.size(), format, ap);
  if (n <= 0) return;
  line.resize(std::min(static_cast<std::size_t>(n), line.size() - 1));
  std::lock_guard<std::mutex> lock(g_msg_mutex);
  if (g_msg.size() < 2000) g_msg += line;
}
std::string take_messages() {
  std::lock_guard<std::mutex> lock(g_msg_mutex);
  std::string m;
  m.swap(g_msg);
  while (!m.empty() && (m.back() == '\n' || m.back() == ' ')) m.pop_back();
  for (char& c : m)
    if (c == '\n') c = ' ';
  return m;
}

// AddressSanitizer maps terabytes of shadow memory: locking it all at once would fault it in.
// Under ASan the pages are locked as they are touched instead.
#if defined(__SANITIZE_ADDRESS__)
#define MACHPLAN_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define MACHPLAN_ASAN 1
#endif
#endif
#ifdef MACHPLAN_ASAN
constexpr int kLockFlags = MCL_CURRENT | MCL_FUTURE | MCL_ONFAULT;
#else
constexpr int kLockFlags = MCL_CURRENT | MCL_FUTURE;
#endif

template <class T>
T load(const T& v) {
  return __atomic_load_n(&v, __ATOMIC_ACQUIRE);
}

// Exchange jitter: |interval between two exchanges - period|, in 1 us bins up to 50 ms.
class JitterHistogram {
 public:
  static constexpr int kBins = 50000;
  JitterHistogram() : bins_(kBins + 1, 0) {}
  void add(double s) noexcept {
    const double us = std::abs(s) * 1e6;
    bins_[static_cast<std::size_t>(std::min<double>(us, kBins))]++;
    max_s_ = std::max(max_s_, std::abs(s));
    ++n_;
  }
  double quantile(double q) const {
    if (n_ == 0) return 0.0;
    const long target = static_cast<long>(std::ceil(q * static_cast<double>(n_)));
    long seen = 0;
    for (int i = 0; i <= kBins; ++i) {
      seen += bins_[i];
      if (seen >= target) return i == kBins ? max_s_ : (i + 0.5) * 1e-6;
    }
    return max_s_;
  }
  double max_s() const { return max_s_; }

 private:
  std::vector<long> bins_;
  double max_s_ = 0.0;
  long n_ = 0;
};

}  // namespace

void HalOptions::validate() const {
  if (!(std::isfinite(period_s) && period_s >= 1e-5 && period_s <= 0.1))
    throw InputError::field("period_s", fmt::format("{} must be 1e-5 .. 0.1 s", period_s));
  for (int i = 0; i < kAxes; ++i) {
    const AxisSignals& s = signals[i];
    if (s.command_latency_ticks < 0 || s.command_latency_ticks > 50)
      throw InputError::field("signals", fmt::format("axis {}: command latency {} must be 0 .. 50 periods", i,
                                                     s.command_latency_ticks));
  }
  if (!start_mm.allFinite()) throw InputError::field("start_mm", "must be finite");
  if (!(std::isfinite(start_tolerance_mm) && start_tolerance_mm > 0 && start_tolerance_mm <= 10))
    throw InputError::field("start_tolerance_mm", fmt::format("{} must be in (0, 10] mm", start_tolerance_mm));
  if (!(std::isfinite(connect_timeout_s) && connect_timeout_s > 0 && connect_timeout_s <= 60))
    throw InputError::field("connect_timeout_s", fmt::format("{} must be in (0, 60] s", connect_timeout_s));
  if (!(std::isfinite(lost_after_s) && lost_after_s >= 0.25 && lost_after_s <= 60))
    throw InputError::field("lost_after_s", fmt::format("{} must be 0.25 .. 60 s (longer than any watchdog)", lost_after_s));
  if (fifo_priority < 1 || fifo_priority > 99)
    throw InputError::field("fifo_priority", fmt::format("{} must be 1 .. 99", fifo_priority));
}

std::string HalTiming::summary() const {
  return fmt::format(
      "HAL exchange: {} exchanges, jitter |interval - period| p50 {:.0f} us, p99 {:.0f} us, p99.9 {:.0f} us, max {:.0f} "
      "us; {} late (the component played the positions planned ahead in {} periods, coasted in {}){}; {}",
      exchanges, jitter_p50_s * 1e6, jitter_p99_s * 1e6, jitter_p999_s * 1e6, jitter_max_s * 1e6, late, played_ahead,
      coasted,
      samples_skipped > 0 ? fmt::format(", {} samples lost to a stall", samples_skipped) : std::string(), realtime_note);
}

struct HalBackend::Impl {
  HalOptions o;
  int comp_id = -1, shmem_id = -1;
  machplan_exchange_block* x = nullptr;
  bool velocity = false;
  int watchdog = 50;
  double period_s = 0.001;
  int queue = 1;  // Q: commands go out this many periods ahead
  std::uint32_t session = 0;

  // exchange state
  bool started = false, lost = false;
  std::uint32_t next = 0;  // the sample the next exchange returns
  std::uint32_t last = 0;  // the sample the last exchange returned
  std::uint32_t ahead_end = 0;  // slots up to this period may hold positions planned ahead
  std::int64_t last_return_ns = 0;
  std::array<std::int32_t, kAxes> raw_base{};   // velocity mode: raw counts of the last sample used
  std::array<std::uint32_t, kAxes> down{};      // the emulated down counters
  std::array<bool, kAxes> dir_negative{};
  bool ruler = false;               // velocity mode with pos-fb linked: an independent measurement
  Eigen::Vector2d ruler_mm = Eigen::Vector2d::Zero();  // pos-fb of the last sample returned
  // Cut recovery: the pin's value when the session opened, and the distance asked since then
  // in the last sample whose pin was a number.
  double recovery_base_mm = 0.0, recovery_mm = 0.0;
  HalTiming timing;
  JitterHistogram jitter;

  // real time
  bool fifo_set = false;
  pthread_t owner{};
  int old_policy = SCHED_OTHER;
  sched_param old_param{};

  void open();
  void close() noexcept;
  void check_pins() const;
  void make_realtime();
  bool newest(machplan_sample& s) const noexcept;
  bool read_sample(std::uint32_t p, machplan_sample& s) const noexcept;
  void write_command(std::uint32_t period, const Outputs& out) noexcept;
  void write_ahead(std::uint32_t period, const Outputs& out) noexcept;
  void fill(const machplan_sample& s, std::uint32_t newest_flags, Inputs& in) noexcept;
};

bool HalBackend::Impl::read_sample(std::uint32_t p, machplan_sample& s) const noexcept {
  const machplan_sample& slot = x->sample[p % MACHPLAN_RING];
  const std::uint32_t q1 = __atomic_load_n(&slot.seq, __ATOMIC_ACQUIRE);
  if (q1 & 1u) return false;
  std::memcpy(&s, &slot, sizeof s);
  __atomic_thread_fence(__ATOMIC_ACQUIRE);
  const std::uint32_t q2 = __atomic_load_n(&slot.seq, __ATOMIC_RELAXED);
  return q1 == q2 && s.period == p;
}

bool HalBackend::Impl::newest(machplan_sample& s) const noexcept {
  for (int attempt = 0; attempt < 8; ++attempt)
    if (read_sample(load(x->count), s)) return true;
  return false;
}

namespace {

// A command slot written under its sequence number (exchange_block.h): odd while `fill` writes it.
template <class Fill>
void write_slot(machplan_command& slot, Fill&& fill) noexcept {
  const std::uint32_t q = slot.seq;
  __atomic_store_n(&slot.seq, q + 1u, __ATOMIC_RELAXED);
  __atomic_thread_fence(__ATOMIC_RELEASE);
  fill(slot);
  __atomic_store_n(&slot.seq, q + 2u, __ATOMIC_RELEASE);
}

}  // namespace

void HalBackend::Impl::write_command(std::uint32_t period, const Outputs& out) noexcept {
  write_slot(x->command[period % MACHPLAN_RING], [&](machplan_command& slot) {
    slot.period = period;
    slot.session = session;
    slot.flags = (out.drives_enabled ? MACHPLAN_CMD_ENABLE : 0u) | (out.torch_fire ? MACHPLAN_CMD_TORCH : 0u) |
                 (out.ohmic_enable ? MACHPLAN_CMD_OHMIC : 0u) | (out.laser_on ? MACHPLAN_CMD_LASER : 0u) |
                 (out.offset_probe ? MACHPLAN_CMD_PROBE : 0u);
    for (int i = 0; i < kAxes; ++i) {
      slot.pos_mm[i] = out.position_command_mm[i];
      const AxisSignals& s = o.signals[i];
      const double full = static_cast<double>(std::int64_t{1} << (std::max(s.dac_bits, 1) - 1));
      slot.vel_mm_per_s[i] = velocity ? out.dac_code[i] / full * s.dac_full_scale_mm_per_s : 0.0;
    }
    slot.height_mm = out.torch_height_target_mm;
  });
}

static_assert(Outputs::kMaxAhead <= static_cast<int>(MACHPLAN_AHEAD_MAX) && MACHPLAN_AHEAD_MAX + 50 < MACHPLAN_RING,
              "the positions planned ahead, with the largest command queue, must stay clear of the slots being read");

// The positions planned for the periods after `period`'s command, each in its own slot; the
// slots a previous exchange filled beyond them are cleared (a period number the component never
// asks of that slot), so that a plan given up (a stop, a hold) is never played.
void HalBackend::Impl::write_ahead(std::uint32_t period, const Outputs& out) noexcept {
  const int n = velocity ? 0 : std::clamp(out.ahead_count, 0, Outputs::kMaxAhead);
  const std::uint32_t end = period + static_cast<std::uint32_t>(n);
  const std::uint32_t stale_end = static_cast<std::int32_t>(ahead_end - end) > 0 ? ahead_end : end;
  for (std::uint32_t p = period + 1; static_cast<std::int32_t>(stale_end - p) >= 0; ++p) {
    machplan_command& slot = x->command[p % MACHPLAN_RING];
    const bool planned = static_cast<std::int32_t>(end - p) >= 0;
    // Written the period before with the same position (the executor's plan only moved on by
    // one period): left as it is. The program is the slots' only writer.
    if (planned && slot.period == p && slot.session == session && slot.flags == MACHPLAN_CMD_AHEAD &&
        std::equal(slot.pos_mm, slot.pos_mm + kAxes, out.ahead_mm[p - period - 1].begin()))
      continue;
    write_slot(slot, [&](machplan_command& slot) {
      slot.period = planned ? p : p - MACHPLAN_RING;
      slot.session = session;
      slot.flags = MACHPLAN_CMD_AHEAD;
      if (planned)
        for (int i = 0; i < kAxes; ++i) slot.pos_mm[i] = out.ahead_mm[p - period - 1][i];
    });
  }
  ahead_end = end;
}

void HalBackend::Impl::fill(const machplan_sample& s, std::uint32_t newest_flags, Inputs& in) noexcept {
  for (int i = 0; i < kAxes; ++i) {
    if (velocity) {
      // The raw counts as the machine file's down counter with a direction bit.
      const std::int32_t d = static_cast<std::int32_t>(static_cast<std::uint32_t>(s.raw_counts[i]) -
                                                       static_cast<std::uint32_t>(raw_base[i]));
      raw_base[i] = s.raw_counts[i];
      const int bits = std::clamp(o.signals[i].counter_bits, 1, 32);
      const std::uint64_t mask = bits == 32 ? 0xFFFFFFFFull : ((std::uint64_t{1} << bits) - 1);
      const std::uint64_t n = static_cast<std::uint64_t>(d < 0 ? -static_cast<std::int64_t>(d) : d);
      down[i] = static_cast<std::uint32_t>((static_cast<std::uint64_t>(down[i]) - n) & mask);
      if (d != 0) dir_negative[i] = d < 0;
      in.counter[i] = down[i];
      in.counter_direction_negative[i] = dir_negative[i];
      in.position_feedback_mm[i] = 0.0;
      ruler_mm[i] = s.fb_mm[i];
    } else {
      in.position_feedback_mm[i] = s.fb_mm[i];
      in.counter[i] = 0;
      in.counter_direction_negative[i] = false;
    }
    in.op.jog[i] = s.jog_deflection[i];
  }
  // The safety flags from the newest sample as well, so that they are reported in the next
  // exchange however far behind the program runs: the E-stop chain, the watchdog, the
  // operator's E-stop and a breakaway (a collision). The float switch and the ohmic contact
  // stay those of the sample's own period, where the torch height they go with was measured.
  constexpr std::uint32_t kUrgent = MACHPLAN_IN_ESTOP | MACHPLAN_IN_WATCHDOG | MACHPLAN_IN_OP_ESTOP | MACHPLAN_IN_BREAKAWAY;
  const std::uint32_t f = s.flags | (newest_flags & kUrgent);
  in.arc_ok = (f & MACHPLAN_IN_ARC_OK) != 0;
  in.estop = (f & MACHPLAN_IN_ESTOP) != 0;
  in.watchdog_tripped = (f & MACHPLAN_IN_WATCHDOG) != 0;
  in.torch_height_mm = s.height_fb_mm;
  in.arc_voltage_v = std::isfinite(s.arc_volts) && s.arc_volts > 0.0 ? s.arc_volts : 0.0;  // 0: not measured
  in.op.feed_hold = (f & MACHPLAN_IN_FEED_HOLD) != 0;
  in.op.cycle_start = (f & MACHPLAN_IN_CYCLE_START) != 0;
  in.op.feed_override_pct = std::isfinite(s.feed_override_pct) ? std::clamp(s.feed_override_pct, 0.0, 200.0) : 100.0;
  in.float_switch = (f & MACHPLAN_IN_FLOAT) != 0;
  in.ohmic_sense = (f & MACHPLAN_IN_OHMIC) != 0;
  in.torch_breakaway = (f & MACHPLAN_IN_BREAKAWAY) != 0;
  in.op.stop = (f & MACHPLAN_IN_STOP) != 0;
  in.op.thc_enabled = (f & MACHPLAN_IN_THC) != 0;
  in.op.torch_enabled = (f & MACHPLAN_IN_TORCH_ENABLE) != 0;
  in.op.estop = (f & MACHPLAN_IN_OP_ESTOP) != 0;
  in.op.rapid_override_pct =
      std::isfinite(s.rapid_override_pct) ? std::clamp(s.rapid_override_pct, 1.0, 100.0) : 100.0;
  // A counter, reported from where it stood when the session opened, so that a value left on
  // the pin by an earlier job is no request. A value that is not a number is no request either:
  // the last good one stands.
  if (std::isfinite(s.recovery_mm)) recovery_mm = s.recovery_mm - recovery_base_mm;
  in.op.paused_motion_mm = recovery_mm;
  // Out of range: clamped; not a number: no motion.
  in.op.paused_motion_speed = std::isfinite(s.paused_speed) ? std::clamp(s.paused_speed, -1.0, 1.0) : 0.0;
}

// ---- opening ------------------------------------------------------------------------------

namespace {

// A pin's link, or why it cannot be read.
struct PinState {
  bool exists = false, linked = false;
};
PinState pin_state(const std::string& name) {
  hal_type_t type;
  hal_data_u* data = nullptr;
  bool connected = false;
  PinState p;
  p.exists = hal_get_pin_value_by_name(name.c_str(), &type, &data, &connected) == 0;
  p.linked = p.exists && connected;
  return p;
}

// A bit parameter. HAL keeps a value only as large and as aligned as its type: read it through
// a copy of that size, not through the union.
bool bit_param(const std::string& name, bool& out) {
  hal_type_t type;
  hal_data_u* data = nullptr;
  if (hal_get_param_value_by_name(name.c_str(), &type, &data) != 0 || !data || type != HAL_BIT) return false;
  bool b;
  std::memcpy(&b, static_cast<const void*>(data), sizeof b);
  out = b;
  return true;
}

bool alive(int pid) { return pid > 0 && (kill(pid, 0) == 0 || errno == EPERM); }

// HAL's real-time side runs in the rtapi_app process (LinuxCNC's own `realtime status` looks for
// it the same way). Without it hal_init() would set up an empty HAL of its own.
bool rtapi_app_running() {
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator("/proc", ec)) {
    const std::string n = e.path().filename().string();
    if (n.empty() || n.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream f(e.path() / "comm");
    std::string comm;
    if (std::getline(f, comm) && comm == "rtapi_app") return true;
  }
  return false;
}

}  // namespace

void HalBackend::Impl::check_pins() const {
  struct Need {
    std::string pin, what;
  };
  std::vector<Need> need;
  need.push_back({"machplan.estop-ok", "the E-stop chain's status (TRUE when closed): machplan must know when it opens"});
  need.push_back({"machplan.enable", "the drives' enable (an amplifier enable, a Mesa card's enable output)"});
  for (int i = 0; i < kAxes; ++i) {
    const std::string ax = fmt::format("machplan.axis.{}.", i);
    if (velocity) {
      need.push_back({ax + "vel-cmd", "the drive's speed command (a DAC or PWM generator, scaled in mm/s)"});
      need.push_back({ax + "counts", "the axis encoder's raw counts"});
    } else {
      need.push_back({ax + "pos-cmd", "the drive's position command"});
      need.push_back({ax + "pos-fb", "the drive's position feedback in mm"});
    }
  }
  if (o.torch) need.push_back({"machplan.torch-on", "the torch's start signal (plasma: the arc start relay)"});
  if (o.arc_ok_signal) need.push_back({"machplan.arc-ok", "the plasma source's arc-OK output"});
  if (o.torch_height) {
    need.push_back({"machplan.torch-height-cmd", "the torch height axis's position command"});
    need.push_back({"machplan.torch-height-fb", "the torch height axis's position feedback"});
  }
  for (const Need& n : need) {
    const PinState p = pin_state(n.pin);
    if (!p.exists)
      fail(fmt::format("HAL has no pin {}: the machplan component loaded is not this version (scripts/setup installs it)",
                       n.pin));
    if (!p.linked)
      fail(fmt::format("{} is not linked: net it to {} ({} mode; docs/hal.md)", n.pin, n.what,
                       velocity ? "velocity" : "position"));
  }
}

void HalBackend::Impl::make_realtime() {
  if (!o.realtime) {
    timing.realtime_note = "real-time scheduling not asked for";
    return;
  }
  std::string why;
  if (mlockall(kLockFlags) != 0) why = fmt::format("mlockall: {}", std::strerror(errno));
  owner = pthread_self();
  if (why.empty()) {
    pthread_getschedparam(owner, &old_policy, &old_param);
    sched_param p{};
    p.sched_priority = o.fifo_priority;
    const int r = pthread_setschedparam(owner, SCHED_FIFO, &p);
    if (r != 0) {
      why = fmt::format("SCHED_FIFO: {}", std::strerror(r));
      munlockall();
    } else {
      fifo_set = true;
    }
  }
  timing.realtime = why.empty();
  if (timing.realtime) {
    timing.realtime_note = fmt::format("real time: SCHED_FIFO priority {}, memory locked", o.fifo_priority);
  } else {
    timing.realtime_note = fmt::format("real time not allowed ({}): ordinary scheduling, late exchanges counted", why);
    static std::atomic<bool> told{false};  // once per process, however many sessions it opens
    if (!told.exchange(true)) std::fprintf(stderr, "machplan: hal: %s\n", timing.realtime_note.c_str());
  }
}

void HalBackend::Impl::open() {
  o.validate();
  if (!rtapi_app_running())
    fail("HAL is not running (no rtapi_app): start the machine's HAL first (scripts/hal-sim up for the simulated "
         "machine; halrun or linuxcnc for a real one)");
  rtapi_set_msg_handler(keep_message);
  take_messages();
  const std::string name = fmt::format("machplan-user-{}", getpid());
  comp_id = hal_init(name.c_str());
  if (comp_id < 0) {
    const std::string m = take_messages();
    fail(fmt::format("HAL is not running{}: start the machine's HAL first (scripts/hal-sim up for the simulated "
                     "machine; halrun or linuxcnc for a real one)",
                     m.empty() ? "" : fmt::format(" ({})", m)));
  }
  hal_ready(comp_id);
  if (!pin_state("machplan.period-count").exists)
    fail("HAL runs but has no machplan component: `loadrt machplan` and `addf machplan servo-thread` in the machine's "
         "HAL file (docs/hal.md; scripts/setup installs the component)");
  if (!bit_param("machplan.velocity-mode", velocity)) fail("cannot read the parameter machplan.velocity-mode");

  shmem_id = rtapi_shmem_new(MACHPLAN_EXCHANGE_KEY, comp_id, sizeof(machplan_exchange_block));
  void* ptr = nullptr;
  if (shmem_id < 0 || rtapi_shmem_getptr(shmem_id, &ptr) != 0 || !ptr)
    fail(fmt::format("cannot attach the machplan component's shared memory ({})", take_messages()));
  x = static_cast<machplan_exchange_block*>(ptr);
  if (load(x->magic) != MACHPLAN_EXCHANGE_MAGIC || x->version != MACHPLAN_EXCHANGE_VERSION)
    fail(fmt::format("the machplan component's shared memory has version {} (this program speaks {}): install the "
                     "component that came with this machplan (scripts/setup) and reload HAL",
                     x->version, MACHPLAN_EXCHANGE_VERSION));

  // Its function must be running.
  const std::int64_t t0 = now_ns(), limit = static_cast<std::int64_t>(o.connect_timeout_s * 1e9);
  const std::uint32_t c0 = load(x->count);
  while (load(x->count) == c0 || load(x->period_ns) == 0) {
    if (now_ns() - t0 > limit)
      fail(fmt::format("the machplan function has not run for {:g} s: add it to the servo thread (`addf machplan "
                       "servo-thread`) and start the threads (`halcmd start`)",
                       o.connect_timeout_s));
    usleep(1000);
  }
  period_s = load(x->period_ns) * 1e-9;
  watchdog = static_cast<int>(load(x->watchdog));
  if (std::abs(period_s - o.period_s) > 1e-6 * o.period_s + 1e-9)
    fail(fmt::format("the HAL thread runs machplan every {:g} ms, the machine file's servo_period_s is {:g} ms: make "
                     "them agree (the thread's period in the HAL file, or servo_period_s)",
                     period_s * 1e3, o.period_s * 1e3));

  // The latencies this exchange has, against the machine file's.
  queue = o.signals[0].command_latency_ticks;
  for (int i = 0; i < kAxes; ++i) {
    const char* ax = i == 0 ? "X" : "Y";
    if (o.signals[i].reading_latency_ticks != 1)
      fail(fmt::format("axis {}: the machine file says latency reading_ticks {}, but feedback through HAL is sampled "
                       "at the start of the period and is one period old: set reading_ticks 1",
                       ax, o.signals[i].reading_latency_ticks));
    if (o.signals[i].command_latency_ticks != queue)
      fail(fmt::format("the machine file's command_ticks differ between the axes ({} and {}): the HAL exchange queues "
                       "commands for both axes alike",
                       o.signals[0].command_latency_ticks, o.signals[i].command_latency_ticks));
  }
  check_pins();
  ruler = velocity && pin_state("machplan.axis.0.pos-fb").linked && pin_state("machplan.axis.1.pos-fb").linked;

  // One session at a time.
  machplan_sample s{};
  if (!newest(s)) fail("cannot read the machplan component's samples (it is being rewritten faster than read)");
  const int owner_pid = load(x->owner_pid);
  if ((s.comp_state == MACHPLAN_STATE_ARMED || s.comp_state == MACHPLAN_STATE_RUNNING) && owner_pid != getpid() &&
      alive(owner_pid))
    fail(fmt::format("another machplan (pid {}) is driving this machine", owner_pid));

  // Take the session.
  session = std::max(load(x->session), load(x->session_ack)) + 1;
  if (session == 0) session = 1;
  __atomic_store_n(&x->owner_pid, static_cast<std::int32_t>(getpid()), __ATOMIC_RELEASE);
  __atomic_store_n(&x->session, session, __ATOMIC_RELEASE);
  const std::int64_t t1 = now_ns();
  while (load(x->session_ack) != session) {
    if (now_ns() - t1 > limit) fail("the machplan component did not take the session (its thread stopped?)");
    usleep(500);
  }
  // A sample of this session.
  const std::uint32_t after = load(x->count) + 1;
  while (static_cast<std::int32_t>(load(x->count) - after) < 0) {
    if (now_ns() - t1 > limit) fail("the machplan component stopped running while the session opened");
    usleep(500);
  }
  if (!newest(s)) fail("cannot read the machplan component's samples");
  recovery_base_mm = std::isfinite(s.recovery_mm) ? s.recovery_mm : 0.0;
  if (!velocity) {
    const Eigen::Vector2d at(s.fb_mm[0], s.fb_mm[1]);
    if ((at - o.start_mm).cwiseAbs().maxCoeff() > o.start_tolerance_mm)
      fail(fmt::format("the machine stands at X {:.3f}, Y {:.3f} mm and the job starts at X {:.3f}, Y {:.3f} mm: move it "
                       "there first (or start the program where the machine stands)",
                       at.x(), at.y(), o.start_mm.x(), o.start_mm.y()));
  }
  for (int i = 0; i < kAxes; ++i) {
    raw_base[i] = s.raw_counts[i];
    const int bits = std::clamp(o.signals[i].counter_bits, 1, 32);
    down[i] = bits >= 16 ? 0x8000u : 0u;  // any value: the decoder works on differences
  }
  make_realtime();
}

void HalBackend::Impl::close() noexcept {
  if (x) {
    __atomic_store_n(&x->closed, session, __ATOMIC_RELEASE);
    if (load(x->owner_pid) == getpid()) __atomic_store_n(&x->owner_pid, 0, __ATOMIC_RELEASE);
  }
  if (shmem_id >= 0) rtapi_shmem_delete(shmem_id, comp_id);
  if (comp_id >= 0) hal_exit(comp_id);
  if (fifo_set && pthread_equal(owner, pthread_self())) pthread_setschedparam(owner, old_policy, &old_param);
  if (timing.realtime) munlockall();
  x = nullptr;
}

// ---- the backend --------------------------------------------------------------------------

HalBackend::HalBackend(const HalOptions& options) : impl_(std::make_unique<Impl>()) {
  impl_->o = options;
  try {
    impl_->open();
  } catch (...) {
    impl_->close();
    throw;
  }
}

HalBackend::~HalBackend() { impl_->close(); }

CommandKind HalBackend::command_kind() const { return impl_->velocity ? CommandKind::speed_dac : CommandKind::position; }
double HalBackend::period_s() const { return impl_->period_s; }
int HalBackend::watchdog_periods() const { return impl_->watchdog; }
int HalBackend::plays_ahead_periods() const { return impl_->velocity ? 0 : Outputs::kMaxAhead; }
std::uint32_t HalBackend::last_period() const { return impl_->last; }

AxisSignals HalBackend::axis_signals(int axis) const {
  AxisSignals s = impl_->o.signals[axis];
  s.command_latency_ticks = impl_->queue;
  s.reading_latency_ticks = 1;
  return s;
}

Inputs HalBackend::initial_inputs() {
  Impl& m = *impl_;
  Inputs in;
  machplan_sample s{};
  if (m.lost || !m.x || !m.newest(s)) return in;
  // The counters as they stand now are the reference: reading them moves no emulated counter.
  std::copy(std::begin(s.raw_counts), std::end(s.raw_counts), m.raw_base.begin());
  m.fill(s, s.flags, in);
  return in;
}

Health HalBackend::exchange(const Outputs& out, Inputs& in) noexcept {
  Impl& m = *impl_;
  if (m.lost || !m.x) return Health::lost;
  machplan_exchange_block* x = m.x;
  if (!m.started) {
    m.next = load(x->count) + 1;
    m.started = true;
  }
  const std::uint32_t s = m.next, tag = s + static_cast<std::uint32_t>(m.queue);
  m.write_command(tag, out);
  m.write_ahead(tag, out);
  if (static_cast<std::int32_t>(load(x->count) - tag) >= 0) ++m.timing.late;

  // Wait for sample s: sleep until it is due, then in short steps; lost after lost_after_s
  // without a new period.
  const std::int64_t period_ns = static_cast<std::int64_t>(m.period_s * 1e9);
  const std::int64_t lost_ns = static_cast<std::int64_t>(m.o.lost_after_s * 1e9);
  std::uint32_t seen = load(x->count);
  std::int64_t progress_ns = now_ns();
  machplan_sample got{};
  bool first_wait = true;
  for (;;) {
    if (load(x->magic) != MACHPLAN_EXCHANGE_MAGIC) {
      m.lost = true;
      return Health::lost;
    }
    const std::uint32_t c = load(x->count);
    const std::int32_t ahead = static_cast<std::int32_t>(c - s);
    if (ahead >= static_cast<std::int32_t>(MACHPLAN_RING / 2)) {
      // So far behind that the ring is being overwritten: go on from the newest.
      m.timing.samples_skipped += ahead;
      m.next = c;
      if (m.read_sample(c, got)) break;
      continue;
    }
    if (ahead >= 0 && m.read_sample(s, got)) break;
    const std::int64_t t = now_ns();
    if (c != seen) {
      seen = c;
      progress_ns = t;
    } else if (t - progress_ns > lost_ns) {
      m.lost = true;
      return Health::lost;
    }
    if (ahead < 0 && first_wait) {
      // Due one period after the newest sample's time stamp, for each period still to come.
      machplan_sample newest{};
      std::int64_t due = t + period_ns / 4;
      if (m.read_sample(c, newest)) due = newest.time_ns + static_cast<std::int64_t>(-ahead) * period_ns + 20000;
      first_wait = false;
      if (due > t && due - t < 4 * period_ns) {
        sleep_until_ns(due);
        continue;
      }
    }
    sleep_until_ns(t + 50000);
  }
  m.last = m.next;
  m.next = m.last + 1;
  if (got.flags & MACHPLAN_IN_AHEAD)
    ++m.timing.played_ahead;
  else if (got.missed > 0 && got.comp_state == MACHPLAN_STATE_RUNNING)
    ++m.timing.coasted;
  machplan_sample latest{};
  const std::uint32_t latest_flags = m.read_sample(load(x->count), latest) ? latest.flags : got.flags;
  m.fill(got, latest_flags, in);

  const std::int64_t t = now_ns();
  if (m.last_return_ns != 0) m.jitter.add((t - m.last_return_ns) * 1e-9 - m.period_s);
  m.last_return_ns = t;
  ++m.timing.exchanges;
  return Health::ok;
}

HalTiming HalBackend::timing() const {
  HalTiming t = impl_->timing;
  t.jitter_p50_s = impl_->jitter.quantile(0.5);
  t.jitter_p99_s = impl_->jitter.quantile(0.99);
  t.jitter_p999_s = impl_->jitter.quantile(0.999);
  t.jitter_max_s = impl_->jitter.max_s();
  return t;
}

bool HalBackend::true_position(Eigen::Vector2d& out_mm) const noexcept {
  if (!impl_->ruler) return false;
  out_mm = impl_->ruler_mm;
  return true;
}

std::vector<std::string> HalBackend::notes() const { return {timing().summary()}; }

}  // namespace machplan::hardware
