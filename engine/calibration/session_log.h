// The calibration session log: what a calibration routine saw on the wire, one row per sample.
//
// Format (CSV, documented for users in datasets/calibration/README.md):
//
//   # machine: thermal_gantry          <- lines starting with '#' are comments, kept in order
//   t_s,axis,dac,counter,dir,ref_mm    <- the header line, exactly these columns
//   0.001,x,0,40000,0,                 <- one sample of one axis
//   0.912,x,0,39871,8,12.3456          <- with a reference (ruler) reading
//
//   t_s      time in s; strictly increasing per axis (the two axes may share a time)
//   axis     x or y
//   dac      the signed speed command written, in DAC steps, -2048 .. 2047
//   counter  the raw 16-bit down counter as read, 0 .. 65535 (it counts down on every encoder
//            edge whichever way the axis moves, and wraps)
//   dir      the direction bit as read: 0 positive, 8 negative (the paper's status bit)
//   ref_mm   an independent measurement of the axis position in mm, or empty
//
// Blank lines are ignored. Every defect (a missing or different header, a truncated row,
// a non-numeric or non-finite field, a value out of range, time not increasing) throws
// InputError "FILE:LINE: what is wrong". A log with no rows is an error as well.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <string_view>
#include <vector>

namespace machplan::calibration {

inline constexpr int kLogAxes = 2;
inline constexpr int kDacMin = -2048, kDacMax = 2047;
inline constexpr std::uint32_t kCounterModulus = 65536;
inline constexpr int kDirNegative = 8;  // the value of the direction bit when moving negative

struct LogSample {
  double t_s = 0.0;
  int axis = 0;  // 0 = x, 1 = y
  std::int32_t dac = 0;
  std::uint32_t counter = 0;
  bool direction_negative = false;
  bool has_ref = false;
  double ref_mm = 0.0;
  int line = 0;  // line in the file, for messages (0 when not read from a file)
};

struct SessionLog {
  std::vector<std::string> comments;  // without the leading '#', trimmed
  std::vector<LogSample> samples;     // in file order
  std::string source;                 // file name used in messages
};

const char* axis_name(int axis);

// Reads a log from text; `source` names it in messages.
SessionLog read_session_log_text(std::string_view text, const std::string& source);
// Reads a log file (read_text_file limits apply).
SessionLog read_session_log(const std::string& path);

// Writes `log` in the format above (comments first, then the header and the rows). Times are
// written with microsecond resolution and reference readings to 0.1 um, so a written log
// reads back with the same samples to that precision.
void write_session_log(std::ostream& out, const SessionLog& log);

}  // namespace machplan::calibration
