#include "engine/programs/gcode_expr.h"

#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <numbers>

#include "engine/common/error.h"

namespace machplan::gcode_expr {
namespace {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;
constexpr double kToleranceEqual = 0.0001;  // LinuxCNC's TOLERANCE_EQUAL

[[noreturn]] void fail(const std::string& message) { throw SyntaxError(message); }

// Bounds the recursion of nested values ("[[[...", "----#", "##...") whatever the line length.
constexpr int kMaxDepth = 200;
thread_local int depth = 0;
struct DepthGuard {
  DepthGuard() {
    if (++depth > kMaxDepth) {
      depth = 0;
      fail(fmt::format("values nested more than {} deep", kMaxDepth));
    }
  }
  ~DepthGuard() {
    if (depth > 0) --depth;
  }
};

bool is_digit(char c) { return c >= '0' && c <= '9'; }
bool is_alpha(char c) { return c >= 'a' && c <= 'z'; }

double read_number(const std::string& s, std::size_t& pos) {
  std::size_t p = pos;
  bool negative = false;
  if (p < s.size() && (s[p] == '+' || s[p] == '-')) {
    negative = s[p] == '-';
    ++p;
  }
  double value = 0.0, frac = 0.1;
  bool digits = false, dot = false;
  for (; p < s.size(); ++p) {
    const char c = s[p];
    if (is_digit(c)) {
      digits = true;
      if (dot) {
        value += (c - '0') * frac;
        frac /= 10.0;
      } else {
        value = value * 10.0 + (c - '0');
      }
    } else if (c == '.' && !dot) {
      dot = true;
    } else {
      break;
    }
  }
  if (!digits) {
    if (pos >= s.size()) fail("a number is missing at the end of the line");
    fail(fmt::format("bad number: '{}' where a number belongs", s[pos]));
  }
  if (p < s.size() && s[p] == '.') fail("bad number: more than one decimal point");
  if (!(std::abs(value) <= kMaxNumber)) fail(fmt::format("number larger than {:g}", kMaxNumber));
  pos = p;
  return negative ? -value : value;
}

enum class Op { none, power, times, divide, mod, plus, minus, eq, ne, gt, ge, lt, le, and_, or_, xor_ };

int precedence(Op op) {
  switch (op) {
    case Op::power: return 4;
    case Op::times:
    case Op::divide:
    case Op::mod: return 3;
    case Op::plus:
    case Op::minus: return 2;
    case Op::eq:
    case Op::ne:
    case Op::gt:
    case Op::ge:
    case Op::lt:
    case Op::le: return 1;
    case Op::and_:
    case Op::or_:
    case Op::xor_: return 0;
    case Op::none: break;
  }
  return -1;
}

bool match(const std::string& s, std::size_t pos, const char* word) {
  return s.compare(pos, std::char_traits<char>::length(word), word) == 0;
}

// Reads the operator at s[pos] (or ']' -> Op::none without moving).
Op read_operator(const std::string& s, std::size_t& pos) {
  if (pos >= s.size()) fail("unclosed expression: ']' missing");
  const char c = s[pos];
  if (c == ']') return Op::none;
  struct Word {
    const char* text;
    Op op;
  };
  static const Word words[] = {{"**", Op::power}, {"*", Op::times}, {"/", Op::divide}, {"mod", Op::mod},
                               {"+", Op::plus},   {"-", Op::minus}, {"eq", Op::eq},    {"ne", Op::ne},
                               {"gt", Op::gt},    {"ge", Op::ge},   {"lt", Op::lt},    {"le", Op::le},
                               {"and", Op::and_}, {"or", Op::or_},  {"xor", Op::xor_}};
  for (const Word& w : words)
    if (match(s, pos, w.text)) {
      pos += std::char_traits<char>::length(w.text);
      return w.op;
    }
  fail(fmt::format("unknown operator in an expression at '{}'", s.substr(pos, 6)));
}

double apply(Op op, double a, double b) {
  switch (op) {
    case Op::power:
      if (a < 0.0 && std::floor(b) != b) fail("attempt to raise a negative number to a non-integer power");
      return std::pow(a, b);
    case Op::times: return a * b;
    case Op::divide:
      if (b == 0.0) fail("attempt to divide by zero");
      return a / b;
    case Op::mod: {
      if (b == 0.0) fail("attempt to divide by zero (MOD)");
      double r = std::fmod(a, b);
      if (r < 0.0) r += std::abs(b);
      return r;
    }
    case Op::plus: return a + b;
    case Op::minus: return a - b;
    case Op::eq: return std::abs(a - b) < kToleranceEqual ? 1.0 : 0.0;
    case Op::ne: return std::abs(a - b) >= kToleranceEqual ? 1.0 : 0.0;
    case Op::gt: return a > b ? 1.0 : 0.0;
    case Op::ge: return a >= b ? 1.0 : 0.0;
    case Op::lt: return a < b ? 1.0 : 0.0;
    case Op::le: return a <= b ? 1.0 : 0.0;
    case Op::and_: return (a != 0.0 && b != 0.0) ? 1.0 : 0.0;
    case Op::or_: return (a != 0.0 || b != 0.0) ? 1.0 : 0.0;
    case Op::xor_: return ((a != 0.0) != (b != 0.0)) ? 1.0 : 0.0;
    case Op::none: break;
  }
  return 0.0;
}

double unary(const std::string& s, std::size_t& pos, const Parameters& params) {
  std::size_t end = pos;
  while (end < s.size() && is_alpha(s[end])) ++end;
  const std::string name = s.substr(pos, end - pos);
  pos = end;
  if (pos >= s.size() || s[pos] != '[')
    fail(fmt::format("'{}' is not a function (a function name must be followed by '[')", excerpt(name)));
  if (name == "exists") {
    ++pos;
    if (pos >= s.size() || s[pos] != '#') fail("EXISTS takes a named parameter: EXISTS[#<name>]");
    ++pos;
    std::string pname;
    if (read_parameter_ref(s, pos, params, pname) >= 0 || pname.empty())
      fail("EXISTS takes a named parameter: EXISTS[#<name>]");
    if (pos >= s.size() || s[pos] != ']') fail("EXISTS takes one named parameter: ']' missing");
    ++pos;
    return params.exists(pname) ? 1.0 : 0.0;
  }
  const double v = read_expression(s, pos, params);
  if (name == "atan") {
    if (pos >= s.size() || s[pos] != '/') fail("ATAN takes two arguments: ATAN[y]/[x]");
    ++pos;
    if (pos >= s.size() || s[pos] != '[') fail("ATAN takes two arguments: ATAN[y]/[x]");
    const double x = read_expression(s, pos, params);
    return std::atan2(v, x) * kDegPerRad;
  }
  if (name == "abs") return std::abs(v);
  if (name == "acos" || name == "asin") {
    if (v < -1.0 || v > 1.0)
      fail(fmt::format("argument to {} out of range: {:g}", name == "acos" ? "ACOS" : "ASIN", v));
    return (name == "acos" ? std::acos(v) : std::asin(v)) * kDegPerRad;
  }
  if (name == "cos") return std::cos(v / kDegPerRad);
  if (name == "sin") return std::sin(v / kDegPerRad);
  if (name == "tan") return std::tan(v / kDegPerRad);
  if (name == "exp") return std::exp(v);
  if (name == "fix") return std::floor(v);
  if (name == "fup") return std::ceil(v);
  if (name == "round") return static_cast<double>(static_cast<long long>(v + (v < 0 ? -0.5 : 0.5)));
  if (name == "ln") {
    if (v <= 0.0) fail(fmt::format("zero or negative argument to LN: {:g}", v));
    return std::log(v);
  }
  if (name == "sqrt") {
    if (v < 0.0) fail(fmt::format("negative argument to SQRT: {:g}", v));
    return std::sqrt(v);
  }
  fail(fmt::format("unknown function '{}'", excerpt(name)));
}

// Operand and operator stacks as in LinuxCNC's read_real_expression; at most 5 levels deep.
double read_expression_body(const std::string& s, std::size_t& pos, const Parameters& params) {
  double values[8];
  Op ops[8];
  int top = 0;
  values[0] = read_real_value(s, pos, params);
  ops[0] = read_operator(s, pos);
  for (;;) {
    const Op op = ops[top];
    if (op == Op::none) break;
    values[top + 1] = read_real_value(s, pos, params);
    const Op next = read_operator(s, pos);
    // Reduce while the pending operator binds at least as tightly as the next one.
    ++top;
    ops[top] = next;
    while (top > 0 && precedence(ops[top - 1]) >= precedence(ops[top])) {
      values[top - 1] = apply(ops[top - 1], values[top - 1], values[top]);
      ops[top - 1] = ops[top];
      --top;
    }
    if (!std::isfinite(values[top])) fail("expression value is not a finite number");
  }
  return values[0];
}

}  // namespace

double read_expression(const std::string& s, std::size_t& pos, const Parameters& params) {
  if (pos >= s.size() || s[pos] != '[') fail("'[' expected");
  ++pos;
  const double v = read_expression_body(s, pos, params);
  ++pos;  // the ']'
  if (!std::isfinite(v)) fail("expression value is not a finite number");
  return v;
}

int read_parameter_ref(const std::string& s, std::size_t& pos, const Parameters& params, std::string& name) {
  name.clear();
  if (pos < s.size() && s[pos] == '<') {
    const std::size_t close = s.find('>', pos);
    if (close == std::string::npos) fail("named parameter not terminated: '>' missing");
    name = s.substr(pos + 1, close - pos - 1);
    if (name.empty()) fail("named parameter with an empty name: #<>");
    pos = close + 1;
    return -1;
  }
  const double v = read_real_value(s, pos, params);
  const double r = std::round(v);
  if (std::abs(v - r) > 0.0001) fail(fmt::format("parameter number #{:g} is not an integer", v));
  if (r < 1 || r > 5602) fail(fmt::format("parameter number #{:g} out of range (1..5602)", r));
  return static_cast<int>(r);
}

double read_real_value(const std::string& s, std::size_t& pos, const Parameters& params) {
  const DepthGuard guard;
  if (pos >= s.size()) fail("a value is missing at the end of the line");
  const char c = s[pos];
  const char next = pos + 1 < s.size() ? s[pos + 1] : '\0';
  if (c == '[') return read_expression(s, pos, params);
  if (c == '#') {
    ++pos;
    std::string name;
    const int n = read_parameter_ref(s, pos, params, name);
    return n < 0 ? params.named(name) : params.numbered(n);
  }
  if ((c == '+' || c == '-') && !is_digit(next) && next != '.') {
    if (next == '+' || next == '-') fail("repeated sign: write one '+' or '-'");
    ++pos;
    const double v = read_real_value(s, pos, params);
    return c == '-' ? -v : v;
  }
  if (is_alpha(c)) return unary(s, pos, params);
  return read_number(s, pos);
}

}  // namespace machplan::gcode_expr
