// O-words (LinuxCNC's interp_o_word.cc): the structure of the file's O-word lines, found
// once before the program runs, and the control flow they make when they run.
#include "engine/programs/internal/gcode_interp.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace machplan::gcode_interp {

// Pairs the O-word lines of the whole file (LinuxCNC finds them by searching the file).
void Reader::match_structure() {
  std::vector<int> open;
  const auto top_is = [&](OKind k, const std::string& label) {
    return !open.empty() && lines_[static_cast<std::size_t>(open.back())].o == k &&
           lines_[static_cast<std::size_t>(open.back())].label == label;
  };
  for (int i = 0; i < static_cast<int>(lines_.size()); ++i) {
    SourceLine& l = lines_[static_cast<std::size_t>(i)];
    if (l.o == OKind::none || !l.o_error.empty()) continue;
    const auto close = [&](OKind opener, const char* what) {
      if (!top_is(opener, l.label)) {
        l.o_error = fmt::format("{} o{} with no matching opening line", what, l.label);
        return -1;
      }
      const int o = open.back();
      open.pop_back();
      return o;
    };
    switch (l.o) {
      case OKind::sub:
        if (subs_.count(l.label)) l.o_error = fmt::format("subroutine o{} defined twice", l.label);
        else subs_[l.label] = i;
        open.push_back(i);
        break;
      case OKind::do_: case OKind::if_: case OKind::repeat: open.push_back(i); break;
      case OKind::while_:
        if (top_is(OKind::do_, l.label)) {
          l.closes_do = true;
          l.partner = open.back();
          lines_[static_cast<std::size_t>(open.back())].partner = i;
          open.pop_back();
        } else {
          open.push_back(i);
        }
        break;
      case OKind::endsub: case OKind::endwhile: case OKind::endrepeat: {
        const OKind opener = l.o == OKind::endsub ? OKind::sub : l.o == OKind::endwhile ? OKind::while_ : OKind::repeat;
        const int o = close(opener, l.o == OKind::endsub     ? "endsub"
                                    : l.o == OKind::endwhile ? "endwhile"
                                                             : "endrepeat");
        if (o >= 0) {
          l.partner = o;
          lines_[static_cast<std::size_t>(o)].partner = i;
        }
        break;
      }
      case OKind::elseif: case OKind::else_: case OKind::endif: {
        if (!top_is(OKind::if_, l.label)) {
          l.o_error = fmt::format("{} o{} with no matching if",
                                  l.o == OKind::endif   ? "endif"
                                  : l.o == OKind::else_ ? "else"
                                                        : "elseif",
                                  l.label);
          break;
        }
        // Chain: the if (or its last clause) points to this clause.
        int k = open.back();
        while (lines_[static_cast<std::size_t>(k)].partner >= 0) k = lines_[static_cast<std::size_t>(k)].partner;
        if (lines_[static_cast<std::size_t>(k)].o == OKind::else_ && l.o != OKind::endif) {
          l.o_error = fmt::format("{} after else in o{}", l.o == OKind::else_ ? "else" : "elseif", l.label);
          break;
        }
        lines_[static_cast<std::size_t>(k)].partner = i;
        if (l.o == OKind::endif) {
          for (int c = open.back(); c != i; c = lines_[static_cast<std::size_t>(c)].partner)
            lines_[static_cast<std::size_t>(c)].endif = i;
          open.pop_back();
        }
        break;
      }
      case OKind::break_: case OKind::continue_: {
        for (auto it = open.rbegin(); it != open.rend(); ++it) {
          const SourceLine& o = lines_[static_cast<std::size_t>(*it)];
          if (o.label == l.label && (o.o == OKind::while_ || o.o == OKind::do_ || o.o == OKind::repeat)) {
            l.partner = *it;
            break;
          }
        }
        if (l.partner < 0)
          l.o_error = fmt::format("{} o{} outside a loop with that label", l.o == OKind::break_ ? "break" : "continue",
                                  l.label);
        break;
      }
      case OKind::return_:  // returns from whatever subroutine is running, as in LinuxCNC
      case OKind::call: case OKind::none: break;
    }
  }
  // Lines left open keep partner -1: like LinuxCNC, that is an error only when the flow needs
  // the end line (a false condition, a definition to skip, a break).
}

std::optional<double> Reader::OWord::value(bool required, const char* what) {
  const std::string& s = l_.code;
  if (pos_ >= s.size()) {
    if (required) r_.fail(fmt::format("o{} {}: '[' and a value expected", l_.label, what));
    return std::nullopt;
  }
  if (s[pos_] != '[') r_.fail(fmt::format("o{} {}: '[' expected after the keyword", l_.label, what));
  try {
    return gcode_expr::read_expression(s, pos_, r_);
  } catch (const gcode_expr::SyntaxError& e) {
    r_.fail(e.what());
  }
}

void Reader::OWord::nothing_after() const {
  if (pos_ < l_.code.size()) r_.fail(fmt::format("unexpected '{}' after the O-word", l_.code.substr(pos_, 12)));
}

const SourceLine& Reader::OWord::line_of(int i) const {
  if (i < 0) r_.fail(fmt::format("o{} is never closed (no matching end line)", l_.label));
  return r_.lines_[static_cast<std::size_t>(i)];
}

int Reader::OWord::end_of(int partner) const {
  if (partner < 0) r_.fail(fmt::format("o{} is never closed (no matching end line)", l_.label));
  return partner;
}

// Runs an O-word line: its keyword's family does the work.
int Reader::control(int pc) {
  const SourceLine& l = lines_[static_cast<std::size_t>(pc)];
  if (!l.o_error.empty()) fail(l.o_error);
  OWord o(*this, l);
  switch (l.o) {
    case OKind::sub: case OKind::endsub: case OKind::return_: case OKind::call: return subroutine(o, pc);
    case OKind::do_: case OKind::while_: case OKind::endwhile: case OKind::repeat: case OKind::endrepeat:
    case OKind::break_: case OKind::continue_:
      return loop(o, pc);
    case OKind::if_: case OKind::elseif: case OKind::else_: case OKind::endif: return conditional(o, pc);
    case OKind::none: break;
  }
  return pc + 1;
}

// sub (skipped where it stands), call (arguments into #1..#30, a new frame), endsub and
// return (the caller's #1..#30 back, #<_value>).
int Reader::subroutine(OWord& o, int pc) {
  const SourceLine& l = o.line();
  if (l.o == OKind::sub) {
    o.nothing_after();
    return o.end_of(l.partner) + 1;  // definitions are skipped when met; a call jumps in
  }
  if (l.o == OKind::endsub || l.o == OKind::return_) {
    const std::optional<double> v = o.value(false, l.o == OKind::return_ ? "return" : "endsub");
    o.nothing_after();
    if (frames_.size() < 2)
      fail(fmt::format("{} o{} reached outside a subroutine call", l.o == OKind::return_ ? "return" : "endsub", l.label));
    const Frame done = std::move(frames_.back());
    frames_.pop_back();
    for (int i = 0; i < 30; ++i) params_[static_cast<std::size_t>(i + 1)] = done.saved[static_cast<std::size_t>(i)];
    globals_["_value"] = v.value_or(0.0);
    globals_["_value_returned"] = v ? 1.0 : 0.0;
    return done.return_pc;
  }
  std::vector<double> args;
  while (o.more()) {
    if (!o.at_bracket())
      fail(fmt::format("o{} call: arguments are [values], found '{}'", l.label, l.code.substr(o.pos(), 12)));
    args.push_back(*o.value(true, "call"));
  }
  if (args.size() > 30) fail(fmt::format("o{} call: more than 30 arguments", l.label));
  const auto it = subs_.find(l.label);
  if (it == subs_.end())
    fail(fmt::format("subroutine o{} is not defined in this file (subroutines from other files are not supported)",
                     l.label));
  if (static_cast<int>(frames_.size()) > kMaxCallDepth)
    fail(fmt::format("subroutine calls nested deeper than {}", kMaxCallDepth));
  Frame f;
  f.return_pc = pc + 1;
  for (int i = 0; i < 30; ++i) {
    f.saved[static_cast<std::size_t>(i)] = params_[static_cast<std::size_t>(i + 1)];
    params_[static_cast<std::size_t>(i + 1)] = i < static_cast<int>(args.size()) ? args[static_cast<std::size_t>(i)] : 0.0;
  }
  frames_.push_back(std::move(f));
  return it->second + 1;
}

// do / while / endwhile, repeat / endrepeat, break, continue.
int Reader::loop(OWord& o, int pc) {
  const SourceLine& l = o.line();
  switch (l.o) {
    case OKind::do_: o.nothing_after(); return pc + 1;
    case OKind::while_: {
      const bool go_on = *o.value(true, "while") != 0.0;
      o.nothing_after();
      if (l.closes_do) return go_on ? l.partner + 1 : pc + 1;
      return go_on ? pc + 1 : o.end_of(l.partner) + 1;
    }
    case OKind::endwhile: o.nothing_after(); return l.partner;
    case OKind::repeat: {
      const double n = *o.value(true, "repeat");
      o.nothing_after();
      const long long count = static_cast<long long>(std::llround(std::clamp(n, -1.0, 1e12)));
      if (count <= 0) return o.end_of(l.partner) + 1;
      frames_.back().repeats[pc] = count - 1;
      return pc + 1;
    }
    case OKind::endrepeat: {
      o.nothing_after();
      long long& left = frames_.back().repeats[l.partner];
      if (left > 0) {
        --left;
        return l.partner + 1;
      }
      return pc + 1;
    }
    default: break;
  }
  // break / continue
  o.nothing_after();
  const SourceLine& loop_line = o.line_of(l.partner);
  if (l.o == OKind::break_) return o.end_of(loop_line.partner) + 1;
  if (loop_line.o == OKind::while_) return l.partner;  // test again
  return o.end_of(loop_line.partner);                  // do: its closing while; repeat: endrepeat
}

// if / elseif / else / endif: the first clause whose condition holds runs; a clause reached
// from the one before it (that ran) jumps past the endif.
int Reader::conditional(OWord& o, int pc) {
  const SourceLine& l = o.line();
  if (l.o == OKind::elseif || l.o == OKind::else_) return o.end_of(l.endif) + 1;  // the branch before it ran
  if (l.o == OKind::endif) {
    o.nothing_after();
    return pc + 1;
  }
  bool taken = *o.value(true, "if") != 0.0;
  o.nothing_after();
  int at = pc;
  while (!taken) {
    at = o.line_of(at).partner;
    const SourceLine& c = o.line_of(at);
    if (c.o != OKind::elseif) return at + 1;  // else: its body; endif: after it
    line_ = c.number;
    std::size_t p = c.rest;
    if (p >= c.code.size() || c.code[p] != '[') fail(fmt::format("o{} elseif: '[' expected after the keyword", c.label));
    try {
      taken = gcode_expr::read_expression(c.code, p, *this) != 0.0;
    } catch (const gcode_expr::SyntaxError& e) {
      fail(e.what());
    }
  }
  return at + 1;
}

}  // namespace machplan::gcode_interp
