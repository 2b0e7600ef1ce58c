#include "solvers/placement/search.h"

#include <chrono>
#include <cmath>
#include <memory>
#include <queue>
#include <set>
#include <tuple>

#include "engine/common/error.h"

namespace machplan::placement {

namespace {
constexpr double kDeg = M_PI / 180.0;
// Boxes at least this large (radius, mm) that the known interferences leave undecided are
// probed for a deep interference before they are split.
constexpr double kProbeRadius_mm = 32.0;

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

bool on_region(const Eigen::AlignedBox2d& r, double x, double y) {
  return x >= r.min().x() - 1e-9 && x <= r.max().x() + 1e-9 && y >= r.min().y() - 1e-9 && y <= r.max().y() + 1e-9;
}

PlacementResult paper_search(const Scene& scene, const PlacementOptions& o) {
  PlacementResult res;
  const SearchSettings& ss = scene.search;
  Checker checker(scene, 0.0, o.stop);
  res.region = placement_region(scene, 0.0);
  if (checker.class1().interferes) {
    res.status = PlacementStatus::unavoidable;
    res.message = fmt::format("class-1 interference ({} at tool-path index {}, clearance {:.2f} mm) cannot be avoided by relocation",
                              checker.class1().what, checker.class1().pose, checker.class1().clearance_mm);
    res.report = checker.report({});
    return res;
  }
  Placement p;
  Eigen::Vector2d prev = Eigen::Vector2d::Zero();
  bool have_prev = false;
  std::set<std::tuple<long, long, long>> seen;
  for (int step = 0; step < ss.paper_max_steps; ++step) {
    if (o.stop.stop_requested()) {
      res.status = PlacementStatus::cancelled;
      res.message = "cancelled";
      break;
    }
    res.trail.push_back(p);
    ++res.placements_examined;
    Finding w;
    const Decision d = checker.decide(p, 0.0, &w, /*peripherals_first=*/true);
    if (d == Decision::feasible) {
      res.status = PlacementStatus::found;
      res.placement = p;
      res.message = fmt::format("free after {} steps", step);
      break;
    }
    const Eigen::Vector2d dir = w.evasion;
    const bool reverse = have_prev && dir.norm() > 0 &&
                         std::acos(std::clamp(dir.dot(prev), -1.0, 1.0)) > ss.reversal_deg * kDeg;
    Placement next = p;
    next.x_mm += ss.paper_step_mm * dir.x();
    next.y_mm += ss.paper_step_mm * dir.y();
    const auto key = std::make_tuple(std::lround(next.x_mm * 100), std::lround(next.y_mm * 100), std::lround(p.pad_mm * 100));
    if (reverse || dir.norm() == 0 || !on_region(res.region, next.x_mm, next.y_mm) || seen.count(key)) {
      p.pad_mm += ss.paper_pad_step_mm;
      have_prev = false;
      if (p.pad_mm > ss.pad_max_mm + 1e-9) {
        res.status = PlacementStatus::no_placement;
        res.message = fmt::format("the search reached the highest pad ({:.0f} mm) "
                                  "without a free placement; last interference: {}",
                                  ss.pad_max_mm, w.what);
        p.pad_mm -= ss.paper_pad_step_mm;
        break;
      }
      continue;
    }
    seen.insert(key);
    prev = dir;
    have_prev = true;
    p = next;
    if (step + 1 == ss.paper_max_steps) {
      res.status = PlacementStatus::gave_up;
      res.message = fmt::format("gave up after {} steps", ss.paper_max_steps);
    }
  }
  if (res.status != PlacementStatus::cancelled) res.report = checker.report(res.status == PlacementStatus::found ? res.placement : p);
  res.verified = res.status == PlacementStatus::found && res.report.free();
  res.counts = checker.counts();
  return res;
}

struct Box {
  long x0, x1, y0, y1, p0, p1;  // grid indices, inclusive
  double dist2;                 // squared grid distance of the nearest xy point to the centre
  std::uint64_t settled = 0;    // known interferences shown absent over the box (Checker::screen)
  bool operator>(const Box& o) const {
    return std::tie(p0, dist2, x0, y0) > std::tie(o.p0, o.dist2, o.x0, o.y0);
  }
};

long nearest_to_zero(long a, long b) { return std::clamp(0L, a, b); }

Box make_box(long x0, long x1, long y0, long y1, long p0, long p1, std::uint64_t settled = 0) {
  const double nx = static_cast<double>(nearest_to_zero(x0, x1)), ny = static_cast<double>(nearest_to_zero(y0, y1));
  return {x0, x1, y0, y1, p0, p1, nx * nx + ny * ny, settled};
}

PlacementResult optimal_for_rotation(const Scene& scene, double rotation_deg, const PlacementOptions& o) {
  PlacementResult res;
  Checker checker(scene, rotation_deg, o.stop);
  res.region = placement_region(scene, rotation_deg);
  if (checker.class1().interferes) {
    res.status = PlacementStatus::unavoidable;
    res.message = fmt::format("class-1 interference ({} at tool-path index {}, clearance {:.2f} mm) cannot be avoided by relocation",
                              checker.class1().what, checker.class1().pose, checker.class1().clearance_mm);
    res.report = checker.report({0, 0, 0, rotation_deg});
    return res;
  }
  const double g = scene.search.resolution_mm;
  const long x0 = static_cast<long>(std::ceil(res.region.min().x() / g)), x1 = static_cast<long>(std::floor(res.region.max().x() / g));
  const long y0 = static_cast<long>(std::ceil(res.region.min().y() / g)), y1 = static_cast<long>(std::floor(res.region.max().y() / g));
  const long p1 = static_cast<long>(std::floor(scene.search.pad_max_mm / g + 1e-9));
  if (x0 > x1 || y0 > y1) {
    res.status = PlacementStatus::no_placement;
    res.message = "the workpiece does not fit on the table";
    return res;
  }
  std::priority_queue<Box, std::vector<Box>, std::greater<>> open;
  open.push(make_box(x0, x1, y0, y1, 0, p1));
  const double total = static_cast<double>(x1 - x0 + 1) * (y1 - y0 + 1) * (p1 + 1);
  double done_volume = 0;
  Finding last;
  std::set<std::tuple<long, long, long>> rejected;  // grid points refused by a certification
  while (!open.empty()) {
    if (o.stop.stop_requested()) {
      res.status = PlacementStatus::cancelled;
      res.message = "cancelled";
      break;
    }
    const Box b = open.top();
    open.pop();
    ++res.placements_examined;
    const Placement centre{(b.x0 + b.x1) * 0.5 * g, (b.y0 + b.y1) * 0.5 * g, (b.p0 + b.p1) * 0.5 * g, rotation_deg};
    const double radius = 0.5 * g * std::sqrt(double((b.x1 - b.x0) * (b.x1 - b.x0) + (b.y1 - b.y0) * (b.y1 - b.y0) +
                                                     (b.p1 - b.p0) * (b.p1 - b.p0)));
    if (radius == 0 && rejected.count({b.x0, b.y0, b.p0})) continue;
    std::uint64_t settled = b.settled;
    Decision d = checker.screen(centre, radius, &settled);
    // A large box no known interference settles: look for a deep one at its centre.
    if (d == Decision::unknown && radius >= kProbeRadius_mm) d = checker.probe(centre, radius);
    const double volume = double(b.x1 - b.x0 + 1) * (b.y1 - b.y0 + 1) * (b.p1 - b.p0 + 1);
    if (d == Decision::infeasible) {
      done_volume += volume;
      if (o.progress) o.progress(done_volume / total);
      continue;
    }
    if (d == Decision::feasible) {
      // No interference met so far objects anywhere in the box, so its best point is the best
      // candidate left: certify it over the whole path. If that fails, the checker has learned
      // the interference and the box is screened again (now infeasible, or split).
      const Placement best{nearest_to_zero(b.x0, b.x1) * g, nearest_to_zero(b.y0, b.y1) * g, b.p0 * g, rotation_deg};
      Finding w;
      ++res.certifications;
      const std::size_t known = checker.known_interferences();
      if (checker.probe(best, 0.0) == Decision::infeasible) {  // a quick look first
        open.push(b);
        continue;
      }
      if (checker.decide(best, 0.0, &w) == Decision::feasible) {
        res.status = PlacementStatus::found;
        res.placement = best;
        res.message = fmt::format("lowest pad, then nearest the centre, on a {:.3g} mm grid", g);
        break;
      }
      last = w;
      if (checker.known_interferences() > known) {
        open.push(b);
        continue;
      }
      // Refused without an exact interfering pose (an interval that could not be proven): the
      // point is out, and the rest of the box is split as usual.
      rejected.insert({nearest_to_zero(b.x0, b.x1), nearest_to_zero(b.y0, b.y1), b.p0});
      if (radius == 0) continue;
    }
    // Split the longest side (grid units); a single grid point is never "unknown" (screen at
    // radius 0 always answers).
    const long sx = b.x1 - b.x0, sy = b.y1 - b.y0, sp = b.p1 - b.p0;
    MACHPLAN_ASSERT(sx + sy + sp > 0, "undecided single placement");
    if (sp >= sx && sp >= sy) {
      const long m = b.p0 + sp / 2;
      open.push(make_box(b.x0, b.x1, b.y0, b.y1, b.p0, m, settled));
      open.push(make_box(b.x0, b.x1, b.y0, b.y1, m + 1, b.p1, settled));
    } else if (sx >= sy) {
      const long m = b.x0 + sx / 2;
      open.push(make_box(b.x0, m, b.y0, b.y1, b.p0, b.p1, settled));
      open.push(make_box(m + 1, b.x1, b.y0, b.y1, b.p0, b.p1));
    } else {
      const long m = b.y0 + sy / 2;
      open.push(make_box(b.x0, b.x1, b.y0, m, b.p0, b.p1, settled));
      open.push(make_box(b.x0, b.x1, m + 1, b.y1, b.p0, b.p1, settled));
    }
  }
  if (res.status != PlacementStatus::found && res.status != PlacementStatus::cancelled) {
    res.status = PlacementStatus::no_placement;
    res.message = fmt::format("no placement on the table with a pad up to {:.0f} mm is "
                              "free of interference{}",
                              scene.search.pad_max_mm, last.what.empty() ? "" : fmt::format(" (e.g. {})", last.what));
  }
  // A cancelled search stops now: no report (it can take as long as the search itself).
  if (res.status != PlacementStatus::cancelled)
    res.report = checker.report(res.status == PlacementStatus::found ? res.placement : Placement{0, 0, 0, rotation_deg});
  res.verified = res.status == PlacementStatus::found && res.report.free();
  res.counts = checker.counts();
  return res;
}
}  // namespace

const char* to_string(PlacementStatus s) {
  switch (s) {
    case PlacementStatus::found: return "found";
    case PlacementStatus::unavoidable: return "unavoidable";
    case PlacementStatus::no_placement: return "no_placement";
    case PlacementStatus::gave_up: return "gave_up";
    case PlacementStatus::cancelled: return "cancelled";
  }
  return "?";
}

Eigen::AlignedBox2d placement_region(const Scene& scene, double rotation_deg) {
  const Eigen::Rotation2Dd R(rotation_deg * kDeg);
  Eigen::AlignedBox2d fp;
  const auto& b = scene.workpiece_bounds;
  for (int k = 0; k < 4; ++k)
    fp.extend(R * Eigen::Vector2d(k & 1 ? b.max().x() : b.min().x(), k & 2 ? b.max().y() : b.min().y()));
  const Eigen::Vector2d half = scene.machine.table_size_mm / 2;
  return Eigen::AlignedBox2d(-half - fp.min(), half - fp.max());
}

namespace {
constexpr Spelling kStrategyNames[] = {{"paper"}, {"optimal"}};
}  // namespace

const char* to_string(PlacementOptions::Strategy s) { return kStrategyNames[static_cast<std::size_t>(s)].name.data(); }

Parsed<PlacementOptions::Strategy> parse_placement_strategy(std::string_view text) {
  const Parsed<std::size_t> p = parse_name(kStrategyNames, text, "strategy", "strategy");
  return {static_cast<PlacementOptions::Strategy>(p.value), p.note};
}

void PlacementOptions::validate() const {
  if (rotations_deg.empty()) throw InputError::field("rotations_deg", "needs at least one rotation");
  if (rotations_deg.size() > kMaxRotations)
    throw InputError::field("rotations_deg",
                            fmt::format("{} rotations; at most {} are searched (each is a whole placement search)",
                                        rotations_deg.size(), kMaxRotations));
  for (std::size_t i = 0; i < rotations_deg.size(); ++i) {
    validate_rotation_deg(rotations_deg[i], "rotations_deg");
    for (std::size_t k = 0; k < i; ++k)
      if (std::abs(std::remainder(rotations_deg[i] - rotations_deg[k], 360.0)) < 1e-9)
        throw InputError::field("rotations_deg",
                                fmt::format("rotation {} deg repeats {} deg; each angle is searched once",
                                            rotations_deg[i], rotations_deg[k]));
  }
}

PlacementResult place(const Scene& scene, const PlacementOptions& o) {
  o.validate();
  const double t0 = now_s();
  PlacementResult best;
  try {
    if (o.strategy == PlacementOptions::Strategy::paper) {
      best = paper_search(scene, o);
    } else {
      bool have = false;
      for (double rot : o.rotations_deg) {
        PlacementResult r = optimal_for_rotation(scene, rot, o);
        const auto key = [](const PlacementResult& x) {
          return std::make_tuple(x.placement.pad_mm, std::hypot(x.placement.x_mm, x.placement.y_mm));
        };
        CheckCounts total = have ? best.counts : CheckCounts{};
        total.add(r.counts);
        const long examined = (have ? best.placements_examined : 0) + r.placements_examined;
        const bool better = !have || (r.status == PlacementStatus::found &&
                                      (best.status != PlacementStatus::found || key(r) < key(best)));
        if (better) best = std::move(r);
        best.counts = total;
        best.placements_examined = examined;
        have = true;
        if (best.status == PlacementStatus::cancelled) break;
      }
    }
  } catch (const Cancelled&) {
    // A stop request inside one decision: no partial answer is certified.
    best = PlacementResult{};
    best.status = PlacementStatus::cancelled;
    best.message = "cancelled";
  }
  best.seconds = now_s() - t0;
  return best;
}

}  // namespace machplan::placement
