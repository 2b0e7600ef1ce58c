// Where an operator's direction and speed come from, for the hybrid guard's manual mode.
//
//   OperatorScript     a scripted operator: a CSV of time, direction and speed (read here)
//   JoystickDecoder    the Linux joystick API's events (struct js_event of <linux/joystick.h>)
//                      decoded into a stick state
//   KeyDecoder         a terminal in raw mode: arrow keys / WASD steer, digits set the speed,
//                      space releases the stick, q (or Enter) ends the manual part
//   LiveOperator       reads a joystick device or the terminal in its own (not real-time)
//                      thread and hands the newest StickState to the servo loop lock-free
//   RawTerminal        puts a terminal in raw mode and restores it on every exit path
//
// The decoders are pure (bytes in, state out) so that tests can feed them fake event streams;
// only LiveOperator touches devices. A missing device is an InputError naming it.
//
// Script format (CSV, '#' starts a comment, blank lines ignored):
//
//     start,120,40                 optional, first data line: where the table stands, mm
//     t_s,direction_deg,speed_mm_per_s      optional header
//     0.0,180,12                   from t = 0 s push toward 180 deg (-X) at 12 mm/s
//     2.5,0,0                      release the stick
//
// Direction is measured counter-clockwise from +X, degrees; speed 0 releases the stick. Times
// rise strictly; the stick holds each row's state until the next row's time; the script ends
// (cycle start) one second after its last row. Errors name FILE:LINE.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <Eigen/Core>

namespace machplan::hardware {

struct ScriptRow {
  double t_s = 0.0;
  double direction_deg = 0.0;
  double speed_mm_per_s = 0.0;
  int line = 0;
};

struct OperatorScript {
  std::string source;
  std::optional<Eigen::Vector2d> start_mm;
  std::vector<ScriptRow> rows;
  // The row in force at time t (nullptr before the first row).
  const ScriptRow* at(double t_s) const;
  double end_s() const { return rows.empty() ? 0.0 : rows.back().t_s + 1.0; }
};

// Throws InputError(source, line, ...) on bad input: a row with other than 3 fields, a field
// that is not a finite number, time not rising, speed negative or above 10 000 mm/s, a start
// row after the first data row, no rows, more than 1 000 000 rows.
OperatorScript parse_operator_script(std::string_view text, const std::string& source);
OperatorScript read_operator_script(const std::string& path);

// The operator's stick: deflection per axis in [-1, 1] and the speed at full deflection.
struct StickState {
  double x = 0.0, y = 0.0;    // -1 .. 1, +y away from the operator (the joystick's up)
  double speed_mm_per_s = 0.0;
  bool quit = false;          // the operator ends the manual part (cycle start)
};

// Decodes the 8-byte events of the Linux joystick API (time u32, value s16, type u8, number
// u8, little endian; JS_EVENT_BUTTON 0x01, JS_EVENT_AXIS 0x02, JS_EVENT_INIT 0x80 or'ed in
// for the initial state). Axis 0 is X and axis 1 is Y (the kernel's Y grows toward the
// operator, so it is negated); a button press of button `quit_button` sets quit. Bytes may
// arrive in any chunking; a partial event waits for the rest.
class JoystickDecoder {
 public:
  explicit JoystickDecoder(double speed_mm_per_s, int quit_button = 0)
      : speed_(speed_mm_per_s), quit_button_(quit_button) {}
  void feed(const unsigned char* bytes, std::size_t n);
  StickState state() const;
  std::size_t events() const { return events_; }

 private:
  double speed_;
  int quit_button_;
  unsigned char pending_[8]{};
  std::size_t have_ = 0, events_ = 0;
  double x_ = 0, y_ = 0;
  bool quit_ = false;
};

// Decodes a raw terminal's bytes: arrows (ESC [ A/B/C/D) or w/a/s/d push up/left/down/right
// at full deflection (two keys combine into a diagonal only by pressing them in turn: each key
// sets its axis and leaves the other), space or x releases the stick, digits 1..9 set the
// speed to that tenth of `max_speed_mm_per_s`, q, Q, Enter or Ctrl-C quit. Unknown bytes are
// ignored.
class KeyDecoder {
 public:
  explicit KeyDecoder(double max_speed_mm_per_s) : max_(max_speed_mm_per_s), speed_(max_speed_mm_per_s) {}
  void feed(const unsigned char* bytes, std::size_t n);
  StickState state() const { return {x_, y_, speed_, quit_}; }

 private:
  double max_, speed_;
  double x_ = 0, y_ = 0;
  bool quit_ = false;
  int esc_ = 0;  // 0: none, 1: ESC seen, 2: ESC [ seen
};

// Raw mode on a terminal file descriptor (no echo, no line buffering, no signals from keys:
// Ctrl-C arrives as a byte the KeyDecoder turns into quit); the previous mode comes back in
// the destructor, and from the SIGINT/SIGTERM/SIGHUP handlers and atexit hook installed while
// one is alive. Throws InputError::field("operator", "keys: ...") when fd is not a terminal.
class RawTerminal {
 public:
  explicit RawTerminal(int fd);
  ~RawTerminal();
  RawTerminal(const RawTerminal&) = delete;
  RawTerminal& operator=(const RawTerminal&) = delete;
};

// A live operator: a reader thread (not real-time) decodes the device and publishes the
// newest StickState through one atomic word (x and y as 16-bit fixed point, the speed in
// 0.01 mm/s, quit), so the servo loop reads it without a lock. kind "joystick" opens `device`
// (default /dev/input/js0); kind "keys" reads standard input in raw mode. Throws InputError
// naming the device when it cannot be opened.
class LiveOperator {
 public:
  enum class Kind { joystick, keys };
  LiveOperator(Kind kind, const std::string& device, double max_speed_mm_per_s);
  ~LiveOperator();
  LiveOperator(const LiveOperator&) = delete;
  LiveOperator& operator=(const LiveOperator&) = delete;
  // Real time: one atomic load.
  StickState read() const noexcept { return unpack(word_.load(std::memory_order_acquire)); }

  static std::uint64_t pack(const StickState& s) noexcept;
  static StickState unpack(std::uint64_t w) noexcept;

 private:
  void loop(Kind kind, double max_speed_mm_per_s);
  int fd_ = -1;
  int wake_[2] = {-1, -1};  // a pipe that ends the reader thread
  std::atomic<std::uint64_t> word_{0};
  std::unique_ptr<RawTerminal> raw_;
  std::thread thread_;
};

}  // namespace machplan::hardware
