// Operator input for the hybrid guard: the scripted operator's CSV (errors name FILE:LINE), the
// Linux joystick API's events and a raw terminal's keys decoded from fake byte streams (no
// device is needed), the lock-free hand-over word, and a clear error for an absent device.
#include <fcntl.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cmath>
#include <cstdint>
#include <thread>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/hardware/operator_input.h"

namespace machplan::hardware {
namespace {

std::string script_error_of(const std::string& text) {
  try {
    parse_operator_script(text, "op.csv");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(OperatorScript, ReadsStartHeaderRowsAndComments) {
  const OperatorScript s = parse_operator_script(
      "# a scripted operator\nstart, 120, -40\nt_s,direction_deg,speed_mm_per_s\n0,180,12  # push -X\n\n2.5,90,18\n4,0,0\n", "op.csv");
  ASSERT_TRUE(s.start_mm);
  EXPECT_EQ(*s.start_mm, Eigen::Vector2d(120, -40));
  ASSERT_EQ(s.rows.size(), 3u);
  EXPECT_EQ(s.rows[1].line, 6);
  EXPECT_DOUBLE_EQ(s.rows[1].direction_deg, 90);
  EXPECT_DOUBLE_EQ(s.rows[1].speed_mm_per_s, 18);
  EXPECT_EQ(s.at(-1.0), nullptr);
  EXPECT_EQ(s.at(0.0), &s.rows[0]);
  EXPECT_EQ(s.at(3.0), &s.rows[1]);
  EXPECT_EQ(s.at(100.0), &s.rows[2]);
  EXPECT_DOUBLE_EQ(s.end_s(), 5.0);
}

TEST(OperatorScript, BadInputNamesFileAndLine) {
  EXPECT_EQ(script_error_of("0,180\n"), "op.csv:1: expected 3 fields (t_s, direction_deg, speed_mm_per_s), found 2");
  EXPECT_EQ(script_error_of("0,180,12\n1,abc,12\n"), "op.csv:2: direction 'abc' is not a finite number");
  EXPECT_EQ(script_error_of("0,180,12\n0,0,12\n"), "op.csv:2: time 0 s does not rise (previous row: 0 s)");
  EXPECT_EQ(script_error_of("0,180,-1\n"), "op.csv:1: speed -1 mm/s must be in [0, 10000]");
  EXPECT_EQ(script_error_of("0,180,nan\n"), "op.csv:1: speed 'nan' is not a finite number");
  EXPECT_EQ(script_error_of("0,180,12\nstart,1,2\n"), "op.csv:2: the start row must come before the first data row, once");
  EXPECT_EQ(script_error_of("# nothing\n"), "op.csv: no data rows (t_s, direction_deg, speed_mm_per_s)");
  EXPECT_EQ(script_error_of("1e400,0,1\n"), "op.csv:1: time '1e400' is not a finite number");
}

TEST(OperatorScript, MissingFileIsNamed) {
  try {
    read_operator_script("/nonexistent/op.csv");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/op.csv"), std::string::npos);
  }
}

// One struct js_event: u32 time, s16 value, u8 type, u8 number, little endian.
std::vector<unsigned char> js_event(std::uint32_t time, std::int16_t value, unsigned char type, unsigned char number) {
  const auto v = static_cast<std::uint16_t>(value);
  return {static_cast<unsigned char>(time), static_cast<unsigned char>(time >> 8), static_cast<unsigned char>(time >> 16),
          static_cast<unsigned char>(time >> 24), static_cast<unsigned char>(v & 0xff), static_cast<unsigned char>(v >> 8),
          type, number};
}

TEST(JoystickDecoder, DecodesAxesButtonsAndInitEventsInAnyChunking) {
  std::vector<unsigned char> stream;
  const auto add = [&stream](const std::vector<unsigned char>& e) { stream.insert(stream.end(), e.begin(), e.end()); };
  add(js_event(0, 0, 0x82, 0));        // initial state of axis 0 (JS_EVENT_INIT | AXIS)
  add(js_event(0, 1, 0x81, 0));        // initial state of button 0, pressed: not a press event
  add(js_event(10, 32767, 0x02, 0));   // X full right
  add(js_event(11, -16384, 0x02, 1));  // kernel Y half up (toward negative) -> +0.5
  add(js_event(12, 1000, 0x02, 3));    // another axis: ignored
  for (std::size_t chunk : {1u, 3u, 8u, 5u}) {
    JoystickDecoder d(20.0);
    for (std::size_t i = 0; i < stream.size(); i += chunk) d.feed(stream.data() + i, std::min(chunk, stream.size() - i));
    const StickState s = d.state();
    SCOPED_TRACE(chunk);
    EXPECT_EQ(d.events(), 5u);
    EXPECT_DOUBLE_EQ(s.x, 1.0);
    EXPECT_NEAR(s.y, 0.5, 1e-4);
    EXPECT_DOUBLE_EQ(s.speed_mm_per_s, 20.0);
    EXPECT_FALSE(s.quit);
  }
  JoystickDecoder d(20.0);
  d.feed(stream.data(), 5);  // a partial event changes nothing
  EXPECT_EQ(d.events(), 0u);
  const auto press = js_event(20, 1, 0x01, 0);
  d.feed(stream.data() + 5, stream.size() - 5);
  d.feed(press.data(), press.size());
  EXPECT_TRUE(d.state().quit);
  const auto extreme = js_event(30, -32768, 0x02, 0);
  d.feed(extreme.data(), extreme.size());
  EXPECT_DOUBLE_EQ(d.state().x, -1.0);  // clamped
}

TEST(KeyDecoder, ArrowsLettersDigitsStopAndQuit) {
  KeyDecoder k(50.0);
  const auto feed = [&k](const std::string& s) { k.feed(reinterpret_cast<const unsigned char*>(s.data()), s.size()); };
  feed("\x1b[A");
  EXPECT_EQ(k.state().y, 1.0);
  feed("\x1b[D");
  EXPECT_EQ(k.state().x, -1.0);
  EXPECT_EQ(k.state().y, 1.0);  // arrows combine
  feed("\x1b");                 // an escape split across reads
  feed("[C");
  EXPECT_EQ(k.state().x, 1.0);
  feed(" ");
  EXPECT_EQ(k.state().x, 0.0);
  EXPECT_EQ(k.state().y, 0.0);
  feed("s5");
  EXPECT_EQ(k.state().y, -1.0);
  EXPECT_DOUBLE_EQ(k.state().speed_mm_per_s, 25.0);
  feed("z!");  // unknown: ignored
  EXPECT_EQ(k.state().y, -1.0);
  EXPECT_FALSE(k.state().quit);
  feed("q");
  EXPECT_TRUE(k.state().quit);
  EXPECT_EQ(k.state().y, 0.0);
  KeyDecoder c(10.0);
  const unsigned char ctrl_c = 0x03;
  c.feed(&ctrl_c, 1);
  EXPECT_TRUE(c.state().quit);
}

TEST(LiveOperator, HandOverWordRoundTrips) {
  const StickState s{0.25, -1.0, 123.45, true};
  const StickState u = LiveOperator::unpack(LiveOperator::pack(s));
  EXPECT_NEAR(u.x, 0.25, 1e-4);
  EXPECT_NEAR(u.y, -1.0, 1e-4);
  EXPECT_NEAR(u.speed_mm_per_s, 123.45, 0.006);
  EXPECT_TRUE(u.quit);
  const StickState n = LiveOperator::unpack(LiveOperator::pack(StickState{std::nan(""), 7.0, -3.0, false}));
  EXPECT_EQ(n.x, 0.0);
  EXPECT_EQ(n.y, 1.0);
  EXPECT_EQ(n.speed_mm_per_s, 0.0);
  EXPECT_FALSE(n.quit);
  static_assert(std::atomic<std::uint64_t>::is_always_lock_free);
}

TEST(LiveOperator, AnAbsentJoystickIsAClearError) {
  try {
    LiveOperator op(LiveOperator::Kind::joystick, "/dev/input/js-machplan-absent", 12.0);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "operator");
    EXPECT_NE(std::string(e.what()).find("joystick: cannot open /dev/input/js-machplan-absent"), std::string::npos)
        << e.what();
  }
}

TEST(LiveOperator, AJoystickDeviceIsReadInItsOwnThread) {
  // A pipe stands in for /dev/input/js0: the reader thread decodes what is written into it.
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  const std::string dev = "/proc/self/fd/" + std::to_string(fds[0]);
  {
    LiveOperator op(LiveOperator::Kind::joystick, dev, 15.0);
    const auto e = js_event(1, -32767, 0x02, 0);
    ASSERT_EQ(write(fds[1], e.data(), e.size()), 8);
    StickState s;
    for (int k = 0; k < 2000 && s.x > -0.5; ++k) {
      s = op.read();
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    EXPECT_NEAR(s.x, -1.0, 1e-4);
    EXPECT_NEAR(s.speed_mm_per_s, 15.0, 0.01);
  }
  close(fds[0]);
  close(fds[1]);
}

// A pseudo-terminal stands in for the operator's terminal.
struct Pty {
  int master = -1, slave = -1;
  Pty() {
    master = posix_openpt(O_RDWR | O_NOCTTY);
    if (master >= 0 && grantpt(master) == 0 && unlockpt(master) == 0) slave = open(ptsname(master), O_RDWR | O_NOCTTY);
  }
  ~Pty() {
    if (slave >= 0) close(slave);
    if (master >= 0) close(master);
  }
};

TEST(RawTerminal, RawWhileAliveAndRestoredAfter) {
  Pty pty;
  ASSERT_GE(pty.slave, 0);
  termios before{};
  ASSERT_EQ(tcgetattr(pty.slave, &before), 0);
  ASSERT_TRUE(before.c_lflag & ICANON);
  {
    RawTerminal raw(pty.slave);
    termios during{};
    ASSERT_EQ(tcgetattr(pty.slave, &during), 0);
    EXPECT_FALSE(during.c_lflag & ICANON);
    EXPECT_FALSE(during.c_lflag & ECHO);
    EXPECT_FALSE(during.c_lflag & ISIG);
    EXPECT_THROW(RawTerminal again(pty.slave), InputError);  // one at a time
  }
  termios after{};
  ASSERT_EQ(tcgetattr(pty.slave, &after), 0);
  EXPECT_EQ(after.c_lflag, before.c_lflag);
  EXPECT_EQ(after.c_iflag, before.c_iflag);
}

TEST(RawTerminal, ASignalRestoresTheModeBeforeTheProcessEnds) {
  Pty pty;
  ASSERT_GE(pty.slave, 0);
  termios before{};
  ASSERT_EQ(tcgetattr(pty.slave, &before), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    RawTerminal raw(pty.slave);
    raise(SIGTERM);  // the handler restores the mode and ends the process with the signal
    _exit(3);
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status));
  EXPECT_EQ(WTERMSIG(status), SIGTERM);
  termios after{};
  ASSERT_EQ(tcgetattr(pty.slave, &after), 0);
  EXPECT_EQ(after.c_lflag, before.c_lflag);
}

TEST(LiveOperator, KeysFromATerminalReachTheLoopAndTheModeComesBack) {
  Pty pty;
  ASSERT_GE(pty.slave, 0);
  const int saved = dup(STDIN_FILENO);
  ASSERT_GE(saved, 0);
  ASSERT_EQ(dup2(pty.slave, STDIN_FILENO), STDIN_FILENO);
  termios before{};
  tcgetattr(STDIN_FILENO, &before);
  {
    LiveOperator op(LiveOperator::Kind::keys, "", 20.0);
    ASSERT_EQ(write(pty.master, "d5", 2), 2);
    StickState s;
    for (int k = 0; k < 2000 && s.x < 0.5; ++k) {
      s = op.read();
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    EXPECT_NEAR(s.x, 1.0, 1e-4);
    for (int k = 0; k < 2000 && std::abs(s.speed_mm_per_s - 10.0) > 0.01; ++k) {
      s = op.read();
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    EXPECT_NEAR(s.speed_mm_per_s, 10.0, 0.01);
    ASSERT_EQ(write(pty.master, "q", 1), 1);
    for (int k = 0; k < 2000 && !s.quit; ++k) {
      s = op.read();
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    EXPECT_TRUE(s.quit);
  }
  termios after{};
  tcgetattr(STDIN_FILENO, &after);
  EXPECT_EQ(after.c_lflag, before.c_lflag);
  dup2(saved, STDIN_FILENO);
  close(saved);
}

TEST(RawTerminal, RefusesWhatIsNotATerminal) {
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  EXPECT_THROW(RawTerminal t(fds[0]), InputError);
  close(fds[0]);
  close(fds[1]);
}

}  // namespace
}  // namespace machplan::hardware
