#include "engine/hardware/operator_input.h"
#include "engine/common/internal/text_scan.h"

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>

#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/common/internal/parse.h"
#include "engine/common/text_file.h"

namespace machplan::hardware {

// ---- the scripted operator ---------------------------------------------------------------

namespace {

using text_scan::trim;

std::vector<std::string_view> split(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t from = 0;
  for (;;) {
    const std::size_t comma = s.find(',', from);
    out.push_back(trim(s.substr(from, comma == std::string_view::npos ? std::string_view::npos : comma - from)));
    if (comma == std::string_view::npos) break;
    from = comma + 1;
  }
  return out;
}

double number(std::string_view f, const std::string& source, int line, const char* what) {
  const std::string text(f);
  const std::optional<double> v = parse_finite(text);
  if (!v) throw InputError(source, line, fmt::format("{} '{}' is not a finite number", what, excerpt(text)));
  return *v;
}

}  // namespace

const ScriptRow* OperatorScript::at(double t_s) const {
  const auto it = std::upper_bound(rows.begin(), rows.end(), t_s, [](double t, const ScriptRow& r) { return t < r.t_s; });
  return it == rows.begin() ? nullptr : &*(it - 1);
}

OperatorScript parse_operator_script(std::string_view text, const std::string& source) {
  OperatorScript s;
  s.source = source;
  int line = 0;
  std::size_t from = 0;
  bool header_allowed = true;
  while (from <= text.size()) {
    const std::size_t nl = text.find('\n', from);
    std::string_view l = text.substr(from, nl == std::string_view::npos ? std::string_view::npos : nl - from);
    from = nl == std::string_view::npos ? text.size() + 1 : nl + 1;
    ++line;
    const std::size_t hash = l.find('#');
    if (hash != std::string_view::npos) l = l.substr(0, hash);
    l = trim(l);
    if (l.empty()) continue;
    const auto f = split(l);
    if (f.size() == 3 && f[0] == "start") {
      if (!s.rows.empty() || s.start_mm)
        throw InputError(source, line, "the start row must come before the first data row, once");
      const Eigen::Vector2d p(number(f[1], source, line, "start x"), number(f[2], source, line, "start y"));
      if (p.cwiseAbs().maxCoeff() > 1e6) throw InputError(source, line, "start lies beyond 1e6 mm");
      s.start_mm = p;
      continue;
    }
    if (f.size() == 3 && header_allowed && f[0] == "t_s") {
      header_allowed = false;
      continue;
    }
    if (f.size() != 3)
      throw InputError(source, line, fmt::format("expected 3 fields (t_s, direction_deg, speed_mm_per_s), found {}", f.size()));
    header_allowed = false;
    ScriptRow r;
    r.line = line;
    r.t_s = number(f[0], source, line, "time");
    r.direction_deg = number(f[1], source, line, "direction");
    r.speed_mm_per_s = number(f[2], source, line, "speed");
    if (r.t_s < 0 || r.t_s > 1e6) throw InputError(source, line, fmt::format("time {} s must be in [0, 1e6]", r.t_s));
    if (!s.rows.empty() && !(r.t_s > s.rows.back().t_s))
      throw InputError(source, line, fmt::format("time {} s does not rise (previous row: {} s)", r.t_s, s.rows.back().t_s));
    if (std::abs(r.direction_deg) > 3600) throw InputError(source, line, fmt::format("direction {} deg beyond +-3600", r.direction_deg));
    if (r.speed_mm_per_s < 0 || r.speed_mm_per_s > 1e4)
      throw InputError(source, line, fmt::format("speed {} mm/s must be in [0, 10000]", r.speed_mm_per_s));
    if (s.rows.size() >= 1000000) throw InputError(source, line, "more than 1 000 000 rows");
    s.rows.push_back(r);
  }
  if (s.rows.empty()) throw InputError(source, 0, "no data rows (t_s, direction_deg, speed_mm_per_s)");
  return s;
}

OperatorScript read_operator_script(const std::string& path) {
  return parse_operator_script(read_text_file(path, std::size_t{64} << 20), path);
}

// ---- decoders ----------------------------------------------------------------------------

void JoystickDecoder::feed(const unsigned char* bytes, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    pending_[have_++] = bytes[i];
    if (have_ < 8) continue;
    have_ = 0;
    ++events_;
    const auto value = static_cast<std::int16_t>(static_cast<std::uint16_t>(pending_[4] | (pending_[5] << 8)));
    const unsigned type = pending_[6] & 0x7fu;  // without JS_EVENT_INIT
    const unsigned number = pending_[7];
    if (type == 0x02) {  // JS_EVENT_AXIS
      const double d = std::clamp(value / 32767.0, -1.0, 1.0);
      if (number == 0) x_ = d;
      else if (number == 1) y_ = -d;  // the kernel's Y grows toward the operator
    } else if (type == 0x01) {  // JS_EVENT_BUTTON
      if (static_cast<int>(number) == quit_button_ && value != 0 && !(pending_[6] & 0x80u)) quit_ = true;
    }
  }
}

StickState JoystickDecoder::state() const { return {x_, y_, speed_, quit_}; }

void KeyDecoder::feed(const unsigned char* bytes, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char c = bytes[i];
    if (esc_ == 1) {
      esc_ = c == '[' ? 2 : 0;
      if (esc_ == 2) continue;
    } else if (esc_ == 2) {
      esc_ = 0;
      switch (c) {
        case 'A': y_ = 1; break;
        case 'B': y_ = -1; break;
        case 'C': x_ = 1; break;
        case 'D': x_ = -1; break;
        default: break;
      }
      continue;
    }
    switch (c) {
      case 0x1b: esc_ = 1; break;
      case 'w': case 'W': y_ = 1; x_ = 0; break;
      case 's': case 'S': y_ = -1; x_ = 0; break;
      case 'd': case 'D': x_ = 1; y_ = 0; break;
      case 'a': case 'A': x_ = -1; y_ = 0; break;
      case ' ': case 'x': case 'X': x_ = y_ = 0; break;
      case 'q': case 'Q': case '\r': case '\n': case 0x03: quit_ = true; x_ = y_ = 0; break;
      default:
        if (c >= '1' && c <= '9') speed_ = max_ * (c - '0') / 10.0;
        break;
    }
  }
}

// ---- the terminal ------------------------------------------------------------------------

namespace {

// One saved mode at a time (there is one terminal); restored by the destructor, the signal
// handlers and atexit. Only async-signal-safe calls in the handler.
struct termios g_saved;
volatile std::sig_atomic_t g_raw_fd = -1;
struct sigaction g_old_int, g_old_term, g_old_hup;

void restore_terminal() {
  const int fd = g_raw_fd;
  if (fd >= 0) {
    tcsetattr(fd, TCSANOW, &g_saved);
    g_raw_fd = -1;
  }
}

void on_signal(int sig) {
  restore_terminal();
  signal(sig, SIG_DFL);
  raise(sig);
}

}  // namespace

RawTerminal::RawTerminal(int fd) {
  if (!isatty(fd))
    throw InputError::field("operator", "keys: standard input is not a terminal (keys need an interactive terminal)");
  if (g_raw_fd >= 0) throw InputError::field("operator", "keys: the terminal is already in raw mode");
  if (tcgetattr(fd, &g_saved) != 0)
    throw InputError::field("operator", fmt::format("keys: cannot read the terminal mode: {}", std::strerror(errno)));
  struct termios raw = g_saved;
  raw.c_lflag &= ~static_cast<tcflag_t>(ICANON | ECHO | ISIG | IEXTEN);
  raw.c_iflag &= ~static_cast<tcflag_t>(IXON | ICRNL);
  raw.c_cc[VMIN] = 1;
  raw.c_cc[VTIME] = 0;
  static bool atexit_set = false;
  if (!atexit_set) {
    std::atexit(restore_terminal);
    atexit_set = true;
  }
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, &g_old_int);
  sigaction(SIGTERM, &sa, &g_old_term);
  sigaction(SIGHUP, &sa, &g_old_hup);
  g_raw_fd = fd;
  if (tcsetattr(fd, TCSANOW, &raw) != 0) {
    restore_terminal();
    throw InputError::field("operator", fmt::format("keys: cannot set raw mode: {}", std::strerror(errno)));
  }
}

RawTerminal::~RawTerminal() {
  restore_terminal();
  sigaction(SIGINT, &g_old_int, nullptr);
  sigaction(SIGTERM, &g_old_term, nullptr);
  sigaction(SIGHUP, &g_old_hup, nullptr);
}

// ---- the live operator -------------------------------------------------------------------

std::uint64_t LiveOperator::pack(const StickState& s) noexcept {
  const auto q = [](double v) {
    return static_cast<std::uint16_t>(static_cast<std::int16_t>(std::lround(std::clamp(std::isfinite(v) ? v : 0.0, -1.0, 1.0) * 32767)));
  };
  const double sp = std::isfinite(s.speed_mm_per_s) ? std::clamp(s.speed_mm_per_s, 0.0, 1e4) : 0.0;
  const auto speed = static_cast<std::uint32_t>(std::lround(sp * 100.0)) & 0x7fffffu;
  return std::uint64_t{q(s.x)} | (std::uint64_t{q(s.y)} << 16) | (std::uint64_t{speed} << 32) |
         (std::uint64_t{s.quit ? 1u : 0u} << 63);
}

StickState LiveOperator::unpack(std::uint64_t w) noexcept {
  StickState s;
  s.x = static_cast<std::int16_t>(static_cast<std::uint16_t>(w & 0xffffu)) / 32767.0;
  s.y = static_cast<std::int16_t>(static_cast<std::uint16_t>((w >> 16) & 0xffffu)) / 32767.0;
  s.speed_mm_per_s = static_cast<double>((w >> 32) & 0x7fffffu) / 100.0;
  s.quit = (w >> 63) != 0;
  return s;
}

LiveOperator::LiveOperator(Kind kind, const std::string& device, double max_speed_mm_per_s) {
  // Errors name the operator option ("operator") and the kind.
  const char* what = kind == Kind::joystick ? "joystick" : "keys";
  if (kind == Kind::joystick) {
    const std::string path = device.empty() ? "/dev/input/js0" : device;
    fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0)
      throw InputError::field("operator", fmt::format("joystick: cannot open {}: {} (is one plugged in? name another device: "
                                                "joystick:/dev/input/jsN)",
                                                excerpt(path), std::strerror(errno)));
  } else {
    fd_ = STDIN_FILENO;
    raw_ = std::make_unique<RawTerminal>(fd_);
  }
  if (::pipe(wake_) != 0) {
    if (kind == Kind::joystick) ::close(fd_);
    throw InputError::field("operator", fmt::format("{}: cannot create a pipe: {}", what, std::strerror(errno)));
  }
  word_.store(pack(StickState{0, 0, max_speed_mm_per_s, false}));
  thread_ = std::thread([this, kind, max_speed_mm_per_s] { loop(kind, max_speed_mm_per_s); });
}

LiveOperator::~LiveOperator() {
  const char c = 'x';
  [[maybe_unused]] const auto n = ::write(wake_[1], &c, 1);
  if (thread_.joinable()) thread_.join();
  ::close(wake_[0]);
  ::close(wake_[1]);
  if (fd_ >= 0 && fd_ != STDIN_FILENO) ::close(fd_);
  raw_.reset();
}

void LiveOperator::loop(Kind kind, double max_speed_mm_per_s) {
  JoystickDecoder js(max_speed_mm_per_s);
  KeyDecoder keys(max_speed_mm_per_s);
  unsigned char buf[256];
  for (;;) {
    struct pollfd p[2] = {{fd_, POLLIN, 0}, {wake_[0], POLLIN, 0}};
    if (::poll(p, 2, -1) < 0) {
      if (errno == EINTR) continue;
      break;
    }
    if (p[1].revents) break;
    if (!(p[0].revents & (POLLIN | POLLHUP | POLLERR))) continue;
    const ssize_t n = ::read(fd_, buf, sizeof buf);
    if (n <= 0) {
      // The device went away (unplugged) or the terminal closed: release the stick and quit.
      word_.store(pack(StickState{0, 0, 0, true}), std::memory_order_release);
      break;
    }
    StickState s;
    if (kind == Kind::joystick) {
      js.feed(buf, static_cast<std::size_t>(n));
      s = js.state();
    } else {
      keys.feed(buf, static_cast<std::size_t>(n));
      s = keys.state();
    }
    word_.store(pack(s), std::memory_order_release);
  }
}

}  // namespace machplan::hardware
