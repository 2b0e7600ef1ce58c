#include "solvers/nesting/bottom_left.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <random>

#include <boost/geometry/index/rtree.hpp>
#include <fmt/format.h>

#include "engine/common/error.h"
#include "solvers/nesting/internal/shape.h"

namespace machplan::nesting {

namespace {

namespace bgi = boost::geometry::index;

// One sheet's parts so far.
struct SheetLayout {
  std::vector<std::pair<const Shape*, Eigen::Vector2d>> parts;  // each shape and where it is
  mutable std::int64_t tests = 0;  // collision tests made
  bgi::rtree<std::pair<Box, std::size_t>, bgi::quadratic<16>> boxes;
  double right_mm = 0.0;

  bool fits(const Shape& s, double x, double y) const {
    ++tests;
    for (auto it = boxes.qbegin(bgi::intersects(moved(s.box, x, y))); it != boxes.qend(); ++it)
      if (meets(s, {x, y}, *parts[it->second].first, parts[it->second].second)) return false;
    return true;
  }
  void add(const Shape& s, double x, double y, bool fixed = false) {
    boxes.insert({moved(s.box, x, y), parts.size()});
    parts.emplace_back(&s, Eigen::Vector2d(x, y));
    if (!fixed) right_mm = std::max(right_mm, s.part_box.max().x() + x), ++placed;
  }
  int placed = 0;  // parts, not counting what the sheet holds fixed
};

struct Spot {
  double x = 0.0, y = 0.0;
  const Shape* shape = nullptr;
};

// The smallest v in [lo, at] where fits(v) holds, by bisection from `at` (which fits), assuming
// the places between fit from some point on; 0.05 mm resolution.
template <class Fits>
double slide(double lo, double at, Fits&& fits) {
  if (fits(lo)) return lo;
  double bad = lo, good = at;
  while (good - bad > 0.05) {
    const double mid = 0.5 * (bad + good);
    (fits(mid) ? good : bad) = mid;
  }
  return good;
}

// The leftmost place for `s` on `sheet` within `usable`, slid left and down; none when it does not fit.
std::optional<Spot> leftmost(const SheetLayout& sheet, const Shape& s, const Eigen::AlignedBox2d& usable) {
  const double xlo = usable.min().x() - s.part_box.min().x(), xhi = usable.max().x() - s.part_box.max().x();
  const double ylo = usable.min().y() - s.part_box.min().y(), yhi = usable.max().y() - s.part_box.max().y();
  if (xhi < xlo || yhi < ylo) return std::nullopt;
  std::vector<double> xs{xlo}, ys{ylo};
  // Against a box, not on it: polygons that touch count as meeting.
  constexpr double kClear = 1e-4;
  for (const auto& [b, i] : sheet.boxes) {
    xs.push_back(b.max_corner().x() - s.box.min_corner().x() + kClear);
    ys.push_back(b.max_corner().y() - s.box.min_corner().y() + kClear);
    ys.push_back(b.min_corner().y() - s.box.max_corner().y() - kClear);
    // Part in part: each of its holes' lower left corner, and its centre (a round hole).
    for (const auto& ring : sheet.parts[i].first->poly.inners()) {
      const Eigen::Vector2d& at = sheet.parts[i].second;
      const Box h = moved(bg::return_envelope<Box>(ring), at.x(), at.y());
      xs.push_back(h.min_corner().x() - s.box.min_corner().x() + kClear);
      ys.push_back(h.min_corner().y() - s.box.min_corner().y() + kClear);
      xs.push_back(0.5 * (h.min_corner().x() + h.max_corner().x() - s.box.min_corner().x() - s.box.max_corner().x()));
      ys.push_back(0.5 * (h.min_corner().y() + h.max_corner().y() - s.box.min_corner().y() - s.box.max_corner().y()));
    }
  }
  auto clean = [](std::vector<double>& v, double lo, double hi) {
    v.erase(std::remove_if(v.begin(), v.end(), [&](double a) { return a < lo - 1e-9 || a > hi + 1e-9; }), v.end());
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end(), [](double a, double b) { return std::abs(a - b) < 1e-6; }), v.end());
  };
  clean(xs, xlo, xhi);
  clean(ys, ylo, yhi);
  for (double x : xs)
    for (double y : ys) {
      if (!sheet.fits(s, x, y)) continue;
      for (int round = 0; round < 3; ++round) {
        const double nx = slide(xlo, x, [&](double v) { return sheet.fits(s, v, y); });
        const double ny = slide(ylo, y, [&](double v) { return sheet.fits(s, nx, v); });
        if (nx == x && ny == y) break;
        x = nx, y = ny;
      }
      return Spot{x, y, &s};
    }
  return std::nullopt;
}

void check(const NestRequest& r) {
  if (r.parts.empty()) throw InputError::field("parts", "no part to nest");
  if (r.quantity.size() != r.parts.size()) throw InputError::field("quantity", "one quantity per part");
  for (int q : r.quantity)
    if (q < 1 || q > 100000) throw InputError::field("quantity", fmt::format("{} must be 1 .. 100000", q));
  if (r.rotations_deg.empty()) throw InputError::field("rotations", "at least one rotation (0: as drawn)");
  if (!r.rotations.empty() && r.rotations.size() != r.parts.size()) throw InputError::field("rotations", "one list per part");
  if (!r.priority.empty() && r.priority.size() != r.parts.size()) throw InputError::field("priority", "one per part");
  if (!r.mirror.empty() && r.mirror.size() != r.parts.size()) throw InputError::field("mirror", "one per part");
  if (!r.any_rotations.empty() && r.any_rotations.size() != r.parts.size()) throw InputError::field("rotations", "one per part");
  if (r.sheets.empty()) throw InputError::field("sheets", "no sheet to nest on");
  for (const Sheet& s : r.sheets)
    if (!(s.margin_mm >= 0 && s.width_mm > 2 * s.margin_mm && s.height_mm > 2 * s.margin_mm && std::isfinite(s.width_mm) &&
          std::isfinite(s.height_mm)))
      throw InputError::field("sheet", fmt::format("{} x {} mm with a margin of {} mm leaves no usable area", s.width_mm,
                                                   s.height_mm, s.margin_mm));
  if (!(r.spacing_mm >= 0 && r.spacing_mm <= 1000)) throw InputError::field("spacing_mm", fmt::format("{} must be in [0, 1000] mm", r.spacing_mm));
  if (!(r.tolerance_mm > 0)) throw InputError::field("tolerance_mm", "must be > 0");
}

using Copy = std::pair<std::size_t, int>;

// One bottom-left fill of the copies in `order` round each sheet's `fixed` shapes; `tests`
// counts its collision tests.
NestResult fill(const NestRequest& r, const ShapeSet& shapes, const ShapeSet& fixed, const std::vector<Copy>& order,
                std::int64_t& tests) {
  std::vector<Eigen::AlignedBox2d> usable;
  for (const Sheet& sh : r.sheets)
    usable.emplace_back(Eigen::Vector2d::Constant(sh.margin_mm), Eigen::Vector2d(sh.width_mm - sh.margin_mm, sh.height_mm - sh.margin_mm));
  std::vector<SheetLayout> sheets(r.sheets.size());
  for (std::size_t k = 0; k < sheets.size(); ++k)
    for (const Shape& f : fixed[k]) sheets[k].add(f, 0, 0, true);
  // The shapes found not to fit on each sheet: a sheet only fills up, so they never will.
  std::vector<std::vector<const Shape*>> full(sheets.size());
  NestResult out;
  for (const auto& [p, c] : order) {
    std::optional<Spot> best;
    int on = -1;
    for (std::size_t k = 0; k < sheets.size() && !best; ++k) {
      for (const Shape& s : shapes[p]) {
        if (std::find(full[k].begin(), full[k].end(), &s) != full[k].end()) continue;
        const std::optional<Spot> spot = leftmost(sheets[k], s, usable[k]);
        if (!spot) full[k].push_back(&s);
        const auto right = [](const Spot& a) { return a.x + a.shape->part_box.max().x(); };
        if (spot && (!best || right(*spot) < right(*best) - 1e-9 || (right(*spot) <= right(*best) + 1e-9 && spot->y < best->y)))
          best = spot, on = static_cast<int>(k);
      }
    }
    if (!best) {
      const bool larger = std::none_of(shapes[p].begin(), shapes[p].end(), [&](const Shape& s) {
        return std::any_of(usable.begin(), usable.end(), [&](const Eigen::AlignedBox2d& u) {
          return s.part_box.sizes().x() <= u.sizes().x() && s.part_box.sizes().y() <= u.sizes().y();
        });
      });
      const Eigen::Vector2d size = bounding_box(r.parts[p].outer).sizes();
      out.unplaced.push_back({p, c, larger ? fmt::format("{:.1f} x {:.1f} mm: larger than the sheet's usable area in every rotation allowed",
                                                         size.x(), size.y())
                                           : std::string("no room left on the sheets")});
      continue;
    }
    sheets[static_cast<std::size_t>(on)].add(*best->shape, best->x, best->y);
    Placement pl;
    pl.part = p;
    pl.copy = c;
    pl.sheet = on;
    pl.rotation_deg = best->shape->rotation_deg;
    pl.mirrored = best->shape->mirrored;
    pl.translate_mm = {best->x, best->y};
    out.placements.push_back(pl);
  }
  for (const SheetLayout& s : sheets) {
    tests += s.tests;
    out.sheets_used += s.placed > 0;
    out.used_length_mm.push_back(s.placed == 0 ? 0.0 : s.right_mm);
  }
  out.fills = 1;
  return out;
}

// Better: fewer copies left out, then fewer sheets, then a shorter last sheet.
bool better(const NestResult& a, const NestResult& b) {
  if (a.unplaced.size() != b.unplaced.size()) return a.unplaced.size() < b.unplaced.size();
  if (a.sheets_used != b.sheets_used) return a.sheets_used < b.sheets_used;
  return a.last_length_mm() < b.last_length_mm() - 1e-9;
}

}  // namespace

double NestResult::last_length_mm() const {
  for (auto it = used_length_mm.rbegin(); it != used_length_mm.rend(); ++it)
    if (*it > 0.0) return *it;
  return 0.0;
}

NestResult bottom_left_nest(const NestRequest& r) {
  Termination one;
  one.set_budget(1, "fills");
  return bottom_left_nest(r, one, 1);
}

NestResult bottom_left_nest(const NestRequest& r, Termination& t, std::uint64_t seed) {
  return bottom_left_nest(r, shapes_of(r), t, seed);
}

ShapeSet shapes_of(const NestRequest& r) {
  check(r);
  ShapeSet shapes;
  for (std::size_t p = 0; p < r.parts.size(); ++p) {
    std::vector<double> turns = r.rotations.empty() || r.rotations[p].empty() ? r.rotations_deg : r.rotations[p];
    if (r.turns_freely(p))
      for (double a : squaring_rotations(r.parts[p], r.tolerance_mm))
        if (std::none_of(turns.begin(), turns.end(), [&](double b) { return std::abs(std::remainder(a - b, 360.0)) < 1e-6; }))
          turns.push_back(a);
    shapes.push_back(make_shapes(r.parts[p], turns, !r.mirror.empty() && r.mirror[p], r.spacing_mm, r.tolerance_mm));
  }
  return shapes;
}

NestResult bottom_left_nest(const NestRequest& r, const ShapeSet& shapes, Termination& t, std::uint64_t seed,
                            const NestResult* first) {
  // The copies by priority, then largest part first (ties: the order given).
  const auto priority = [&](std::size_t p) { return r.priority.empty() ? 1 : r.priority[p]; };
  std::vector<Copy> order;
  for (std::size_t p = 0; p < r.parts.size(); ++p)
    for (int c = 0; c < r.quantity[p]; ++c) order.emplace_back(p, c);
  std::stable_sort(order.begin(), order.end(), [&](const Copy& a, const Copy& b) {
    if (priority(a.first) != priority(b.first)) return priority(a.first) < priority(b.first);
    return r.parts[a.first].area_mm2 > r.parts[b.first].area_mm2;
  });
  ShapeSet fixed;
  for (const Sheet& sheet : r.sheets) fixed.push_back(sheet_obstacles(sheet, r.spacing_mm, r.tolerance_mm));
  std::int64_t tests = 0;
  std::int64_t steps = meets_steps();
  // Each fill's work: its collision tests and the steps of their exact tests.
  const auto charge = [&] {
    t.charge(1, static_cast<double>(tests) * kTestCostS + static_cast<double>(meets_steps() - steps) * kMeetsStepCostS);
    steps = meets_steps();
  };
  NestResult best = first ? *first : fill(r, shapes, fixed, order, tests);
  charge();
  std::mt19937_64 rng(seed);
  int fills = 1;
  while (order.size() > 1 && !t.should_end()) {
    std::vector<Copy> tried = order;
    std::uniform_int_distribution<std::size_t> pick(0, tried.size() - 1);
    const int swaps = 1 + static_cast<int>(rng() % 3);
    for (int k = 0; k < swaps; ++k) {
      // Two copies of one priority: the must-nest parts stay ahead of the fillers.
      const std::size_t i = pick(rng), j = pick(rng);
      if (priority(tried[i].first) == priority(tried[j].first)) std::swap(tried[i], tried[j]);
    }
    tests = 0;
    NestResult n = fill(r, shapes, fixed, tried, tests);
    charge();
    ++fills;
    if (better(n, best)) best = std::move(n), order = std::move(tried);
  }
  best.fills = fills;
  return best;
}

}  // namespace machplan::nesting
