// Values on an RS274NGC line as LinuxCNC's interpreter reads them: numbers, parameters
// (#1, #<name>, ##2, #[1+2]), expressions in brackets and the unary functions.
// Internal to the G-code reader (engine/programs/gcode.cpp): not a public interface.
//
// The line has already been cleaned (comments and blanks removed, letters lower-cased), as
// LinuxCNC does before it reads words. Semantics follow LinuxCNC's interp_read.cc and
// interp_execute.cc:
//   * binary operators, from the loosest to the tightest binding: AND OR XOR; EQ NE GT GE LT LE;
//     + -; * / MOD; ** (power). Operators of one level bind left to right.
//   * EQ and NE compare within 0.0001 (LinuxCNC's TOLERANCE_EQUAL); logical operators treat
//     0 as false and give 1 or 0; MOD gives a result with the sign of the divisor's magnitude
//     (fmod, then + |divisor| when negative).
//   * functions: ABS ACOS ASIN COS EXP FIX FUP ROUND LN SIN SQRT TAN take [expr]; ATAN takes
//     [y]/[x]; EXISTS takes [#<name>]. Angles in degrees. ROUND rounds half away from zero.
//   * a '-' or '+' not followed by a digit or '.' applies to the value after it ("-#1",
//     "-[2]"), so "-#4*#1" is (-#4) * #1, as in LinuxCNC.
//   * errors LinuxCNC reports are errors here: division by zero, ACOS/ASIN outside [-1, 1],
//     LN of a value <= 0, SQRT of a negative value, a negative number to a non-integer power,
//     unknown operators and functions, unclosed brackets.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>

namespace machplan::gcode_expr {

// A value that cannot be read; the reader adds the file and line.
struct SyntaxError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Where parameter values come from.
class Parameters {
 public:
  virtual ~Parameters() = default;
  // #n; throws SyntaxError when n is out of range.
  virtual double numbered(int n) const = 0;
  // #<name> (lower case, no blanks); throws SyntaxError when it has no value.
  virtual double named(const std::string& name) const = 0;
  virtual bool exists(const std::string& name) const = 0;
};

// Reads one value at line[pos] (a number, parameter, expression, function or signed value)
// and moves pos past it.
double read_real_value(const std::string& line, std::size_t& pos, const Parameters& params);

// Reads a parameter reference after its '#' (line[pos] is the character after '#'):
// either "<name>" (sets `name`, returns -1) or a value giving the number (returns it).
int read_parameter_ref(const std::string& line, std::size_t& pos, const Parameters& params, std::string& name);

// Reads "[expr]" at line[pos].
double read_expression(const std::string& line, std::size_t& pos, const Parameters& params);

// Largest magnitude of a number written in a program.
inline constexpr double kMaxNumber = 1e9;

}  // namespace machplan::gcode_expr
