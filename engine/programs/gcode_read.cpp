// Reading: a file into cleaned lines, a line into words (LinuxCNC's interp_read.cc), and
// the signs of a GRBL program.
#include "engine/programs/internal/gcode_interp.h"

#include <algorithm>
#include <cstring>
#include <string>

namespace machplan::gcode_interp {
namespace {

// The inside of the first comment "(o=...)" of a raw line (blanks before "o=" allowed), or "".
std::string magic_comment(const std::string& raw) {
  for (std::size_t open = raw.find('('); open != std::string::npos; open = raw.find('(', open + 1)) {
    const std::size_t close = raw.find(')', open);
    if (close == std::string::npos) return {};
    std::size_t k = open + 1;
    while (k < close && (raw[k] == ' ' || raw[k] == '\t')) ++k;
    if (k + 1 < close && (raw[k] == 'o' || raw[k] == 'O') && raw[k + 1] == '=') return raw.substr(open + 1, close - open - 1);
  }
  return {};
}

// A line of GRBL real-time commands only ('?' status report, '~' cycle start, '!' feed hold,
// blanks between): a GRBL sender sends such characters at once, outside the stream of lines.
bool is_realtime_line(const std::string& raw) {
  bool any = false;
  for (char c : raw) {
    if (c == '?' || c == '~' || c == '!') any = true;
    else if (c != ' ' && c != '\t') return false;
  }
  return any;
}

}  // namespace

OKind o_kind_of(const std::string& word) {
  static const std::pair<const char*, OKind> words[] = {
      {"sub", OKind::sub},         {"endsub", OKind::endsub},     {"call", OKind::call},
      {"do", OKind::do_},          {"while", OKind::while_},      {"endwhile", OKind::endwhile},
      {"if", OKind::if_},          {"elseif", OKind::elseif},     {"else", OKind::else_},
      {"endif", OKind::endif},     {"repeat", OKind::repeat},     {"endrepeat", OKind::endrepeat},
      {"return", OKind::return_},  {"break", OKind::break_},      {"continue", OKind::continue_}};
  for (const auto& [w, k] : words)
    if (word == w) return k;
  return OKind::none;
}

// Removes comments, spaces and tabs; lower-cases. Nested and unclosed comments set `error`.
std::string Reader::clean(const std::string& raw, std::string& error) const {
  std::string out;
  out.reserve(raw.size());
  bool in_comment = false;
  for (char c : raw) {
    if (in_comment) {
      if (c == ')') in_comment = false;
      else if (c == '(' && error.empty()) error = "nested comment: '(' inside a comment";
      continue;
    }
    if (c == '(') { in_comment = true; continue; }
    if (c == ';') break;
    if (c == ' ' || c == '\t' || c == '\r') continue;
    out.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  }
  if (in_comment && error.empty()) error = "unclosed comment: '(' without ')' on the line";
  return out;
}

// Recognises "[/][nNNN]o<label> keyword" and fills l.o, l.label, l.rest.
void Reader::scan_o_word(SourceLine& l) const {
  const std::string& s = l.code;
  std::size_t p = 0;
  if (p < s.size() && s[p] == '/') ++p;
  if (p < s.size() && s[p] == 'n') {
    ++p;
    while (p < s.size() && (std::isdigit(static_cast<unsigned char>(s[p])) || s[p] == '.')) ++p;
  }
  if (p >= s.size() || s[p] != 'o') return;
  ++p;
  if (p < s.size() && s[p] == '<') {
    const std::size_t close = s.find('>', p);
    if (close == std::string::npos) {
      l.o_error = "O-word name not terminated: '>' missing";
      l.o = OKind::call;  // any kind: the error is reported when the line runs
      return;
    }
    l.label = s.substr(p, close - p + 1);
    p = close + 1;
  } else {
    std::size_t q = p;
    while (q < s.size() && std::isdigit(static_cast<unsigned char>(s[q]))) ++q;
    if (q == p) {
      l.o_error = "O word without a number or <name>";
      l.o = OKind::call;
      return;
    }
    l.label = std::to_string(std::stoll(s.substr(p, std::min<std::size_t>(q - p, 15))));
    p = q;
  }
  std::size_t q = p;
  while (q < s.size() && std::isalpha(static_cast<unsigned char>(s[q]))) ++q;
  const std::string word = s.substr(p, q - p);
  l.o = o_kind_of(word);
  l.rest = q;
  if (l.o == OKind::none) {
    l.o = OKind::call;
    l.o_error = word.empty() ? fmt::format("O-word o{} without a keyword (sub, call, while, if, ...)", l.label)
                             : fmt::format("unknown O-word keyword '{}'", excerpt(word));
  }
}

double Reader::value_at(const std::string& code, std::size_t& pos) {
  try {
    return gcode_expr::read_real_value(code, pos, *this);
  } catch (const gcode_expr::SyntaxError& e) {
    fail(e.what());
  }
}

Block Reader::split(const std::string& code) {
  Block b;
  std::size_t pos = 0;
  if (pos < code.size() && code[pos] == '/') ++pos;  // block delete is off: the line runs
  if (pos < code.size() && code[pos] == 'n') {       // line number
    ++pos;
    (void)value_at(code, pos);
  }
  while (pos < code.size()) {
    const char c = code[pos];
    if (c == '#') {
      ++pos;
      std::string name;
      int n = -1;
      try {
        n = gcode_expr::read_parameter_ref(code, pos, *this, name);
      } catch (const gcode_expr::SyntaxError& e) {
        fail(e.what());
      }
      if (pos >= code.size() || code[pos] != '=') fail("parameter without '=' and a value to set it to");
      ++pos;
      const double v = value_at(code, pos);
      if (n < 0) b.set_named.emplace_back(name, v);
      else b.set_numbered.emplace_back(n, v);
      continue;
    }
    if (c == '$') {
      ++pos;
      const double v = value_at(code, pos);
      if (b.spindle) fail("multiple $ words on one line");
      if (std::abs(v - std::round(v)) > 1e-4) fail(fmt::format("spindle number ${:g} is not an integer", v));
      b.spindle = static_cast<int>(std::round(v));
      continue;
    }
    if (c == '[') fail("an expression ([...]) must follow a word letter");
    if (c == '%') fail("'%' is only allowed on a line of its own opening and closing the program");
    if (c == '@' || c == '^') fail("polar coordinates (@ and ^ words) are not supported");
    if (c == 'o') fail("O word must be first on its line");
    if (c == 'n') fail("N word (line number) is only allowed at the start of a line");
    if (!std::isalpha(static_cast<unsigned char>(c))) {
      if (std::isprint(static_cast<unsigned char>(c))) fail(fmt::format("bad character '{}'", c));
      fail(fmt::format("bad character (byte 0x{:02x})", static_cast<unsigned>(static_cast<unsigned char>(c))));
    }
    ++pos;
    const char L = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    if (pos >= code.size()) fail(fmt::format("{} word without a value", L));
    const double v = value_at(code, pos);
    switch (c) {
      case 'g': {
        if (v < 0) fail(fmt::format("negative G code G{:g}", v));
        const double tenfold = v * 10.0;
        const long long g10 = std::llround(tenfold);
        if (std::abs(tenfold - static_cast<double>(g10)) > 1e-4 || g10 > 9999)
          fail(fmt::format("unknown G code G{:g}", v));
        b.g10.push_back(static_cast<int>(g10));
        break;
      }
      case 'm': {
        if (v < 0) fail(fmt::format("negative M code M{:g}", v));
        const long long m = std::llround(v);
        if (std::abs(v - static_cast<double>(m)) > 1e-4 || m > 9999)
          fail(fmt::format("M code M{:g} is not an integer", v));
        if (b.m.size() >= 4) fail("more than 4 M codes on one line");
        b.m.push_back(static_cast<int>(m));
        break;
      }
      case 'x': case 'y': case 'z': case 'i': case 'j': case 'k': case 'r': case 'f': case 's': case 'p':
      case 't': case 'h': case 'l': case 'q': case 'e': case 'd':
        if (b.w(c)) fail(fmt::format("multiple {} words on one line", L));
        b.w(c) = v;
        break;
      case 'a': case 'b': case 'c': case 'u': case 'v': case 'w':
        fail(fmt::format("{} axis words are not supported (only X, Y and Z)", L));
      default: fail(fmt::format("bad character '{}'", c));
    }
  }
  return b;
}

// Reads the file into lines (cleaned, O-words recognised); returns whether a closing '%'
// ended it.
bool Reader::read_lines(const std::string& text) {
  const bool grbl = program_.dialect == GcodeDialect::grbl;
  std::size_t start = 0;
  bool percent_mode = false;
  int number = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    ++number;
    // A binary file is told apart before its bytes are read as words (and before its long
    // "lines" meet the length limit): no text program holds a NUL byte.
    if (std::memchr(text.data() + start, '\0', end - start) != nullptr) {
      line_ = number;
      fail("not a text file (a NUL byte on this line): a G-code program is text");
    }
    std::string raw = text.substr(start, std::min(end - start, options_.max_line_chars + 2));
    if (!raw.empty() && raw.back() == '\r') raw.pop_back();
    start = end + 1;
    SourceLine l;
    l.number = number;
    if (raw.size() > options_.max_line_chars) {
      l.error = fmt::format("line is longer than {} characters", options_.max_line_chars);
      lines_.push_back(std::move(l));
      continue;
    }
    const auto first = raw.find_first_not_of(" \t");
    if (first != std::string::npos && raw[first] == '%') {
      if (grbl) continue;  // GRBL: '%' lines are ignored wherever they stand
      // LinuxCNC: '%' lines open and close the program.
      if (number == 1) { percent_mode = true; continue; }
      if (percent_mode) return true;
    }
    if (first != std::string::npos && is_realtime_line(raw)) {
      if (!grbl) {
        l.error = fmt::format("'{}' is a GRBL real-time command, which a GRBL sender strips before streaming; "
                              "LinuxCNC has no such line: read the program in the grbl dialect",
                              raw.substr(first, 1));
        lines_.push_back(std::move(l));
        continue;
      }
      if (realtime_lines_++ == 0) first_realtime_line_ = number;
      continue;  // GRBL: skipped, as the sender skips it
    }
    if (grbl && first != std::string::npos && raw[first] == '$') {
      l.system_command = true;
      const auto last = raw.find_last_not_of(" \t");
      l.text = raw.substr(first, last - first + 1);
      lines_.push_back(std::move(l));
      continue;
    }
    l.code = clean(raw, l.error);
    if (l.error.empty()) scan_o_word(l);
    if (options_.report_magic_comments) l.magic = magic_comment(raw);
    lines_.push_back(std::move(l));
  }
  return false;
}

GrblSign grbl_sign(const std::string& text) {
  int number = 0;
  bool percent_first = false;
  for (std::size_t start = 0; start < text.size();) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    ++number;
    std::size_t p = text.find_first_not_of(" \t", start);
    const char c = p < end ? text[p] : '\0';
    start = end + 1;
    if (c == '%') {
      if (number == 1) percent_first = true;
      else if (!percent_first) return {number, "a '%' line inside the program"};
      continue;
    }
    if (c == '?' || c == '~' || c == '!') {
      if (is_realtime_line(text.substr(p, end - p - (end > p && text[end - 1] == '\r' ? 1 : 0))))
        return {number, "a GRBL real-time command line"};
      continue;
    }
    if (c != '$') continue;
    ++p;
    if (p >= end || text[p] == '\r' || std::isalpha(static_cast<unsigned char>(text[p])) || text[p] == '$' ||
        text[p] == '#')
      return {number, "a GRBL system command line"};
    while (p < end && std::isdigit(static_cast<unsigned char>(text[p]))) ++p;
    if (p < end && text[p] == '=' && text[p - 1] != '$') return {number, "a GRBL setting line"};
  }
  return {};
}

}  // namespace machplan::gcode_interp
