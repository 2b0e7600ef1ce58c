#include "solvers/motion/rapid_planner.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <ompl/base/MotionValidator.h>
#include <ompl/base/PlannerTerminationCondition.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/StateValidityChecker.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/datastructures/NearestNeighborsLinear.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/util/Console.h>

#include "engine/common/error.h"

namespace machplan::motion {
namespace {

namespace ob = ompl::base;
namespace og = ompl::geometric;
using Eigen::Vector2d;
using Polyline = std::vector<Vector2d>;


double path_length(const Polyline& p) {
  double s = 0.0;
  for (std::size_t i = 1; i < p.size(); ++i) s += (p[i] - p[i - 1]).norm();
  return s;
}

// Mixes the user's seed with an attempt number and a role into a non-zero 32-bit seed
// (splitmix64 finaliser).
std::uint32_t derive_seed(std::uint32_t seed, int attempt, int role) {
  std::uint64_t z = (static_cast<std::uint64_t>(seed) << 32) ^ (static_cast<std::uint64_t>(attempt) << 8) ^
                    static_cast<std::uint64_t>(role);
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  const auto s = static_cast<std::uint32_t>(z);
  return s == 0 ? 1u : s;
}

// ---------------------------------------------------------------------------------------
// Step 1b: the straight move leaves the cut part it starts at (or reaches the one it ends at)
// directly. See the file comment of rapid_planner.h.

bool leaves_directly(const Vector2d& from, const Vector2d& to, const ZoneSet& zones, std::size_t first_part) {
  const double c = zones.clearance();
  const double len = (to - from).norm();
  if (!(len > 0.0)) return false;
  const Vector2d u = (to - from) / len;
  const std::vector<std::size_t> at_start = zones.near(from, c), at_end = zones.near(to, c);
  if (at_start.empty() && at_end.empty()) return false;
  for (const auto* ends : {&at_start, &at_end})
    for (std::size_t j : *ends)
      if (j < first_part) return false;  // a declared zone: never relaxed
  const auto in = [](const std::vector<std::size_t>& v, std::size_t j) { return std::binary_search(v.begin(), v.end(), j); };
  const double near = std::min(2.0 * c, 0.5 * len);
  const double eps = 1e-6 * std::max(1.0, len);
  const Vector2d p1 = from + near * u, p2 = to - near * u;
  // The middle keeps the full clearance from every zone.
  if (len > 2.0 * near && !zones.segment_clear(p1, p2)) return false;
  // Each end leg keeps it from the zones not at its end, and does not enter those at its end.
  ZoneSet::Skip skip_start(zones.size(), 0), skip_end(zones.size(), 0);
  for (std::size_t j : at_start) skip_start[j] = 1;
  for (std::size_t j : at_end) skip_end[j] = 1;
  if (!zones.segment_clear(from + eps * u, p1, skip_start) || !zones.segment_clear(p2, to - eps * u, skip_end)) return false;
  for (std::size_t j : at_start)
    if (!(zones.segment_distance(from + eps * u, p1, j, c) > 0.0)) return false;
  for (std::size_t j : at_end)
    if (!(zones.segment_distance(p2, to - eps * u, j, c) > 0.0)) return false;
  (void)in;
  return true;
}

// ---------------------------------------------------------------------------------------
// Step 2: leaving the clearance band of the zones that hold an end point.

struct Escape {
  bool ok = true;
  Vector2d point = Vector2d::Zero();
  std::vector<std::size_t> relaxed;  // zones whose band held the end point
  std::string why;
};

// The outward normal of zone j at its boundary point nearest to q (q inside: towards the
// boundary, through the zone). False when no side is outside.
bool outward(const ZoneSet& zones, std::size_t j, const Vector2d& q, ContourPoint& cp, Vector2d& n) {
  const Contour& zone = zones.contour(j);
  cp = closest_point(zone, q);
  const bool inside = contains(zone, q);
  if (cp.distance > 1e-9) {
    n = (q - cp.point) / cp.distance;
    if (inside) n = -n;
    return true;
  }
  // On the boundary: the normal of the span, on the side that is not inside.
  const Vector2d t = tangent_at(zones.spans(j)[cp.span], cp.point);
  n = Vector2d(t.y(), -t.x());
  const double c = zones.clearance();
  const bool plus_in = contains(zone, cp.point + c * n), minus_in = contains(zone, cp.point - c * n);
  if (plus_in && !minus_in) n = -n;
  return !(plus_in && minus_in);
}

Escape escape_from(const Vector2d& p, const ZoneSet& zones, const Eigen::AlignedBox2d& bounds) {
  Escape e;
  e.point = p;
  const double c = zones.clearance();
  e.relaxed = zones.near(p, c);
  if (e.relaxed.empty()) return e;
  ZoneSet::Skip relaxed(zones.size(), 0);
  for (std::size_t j : e.relaxed) relaxed[j] = 1;

  // Push out of the most violated band, a few times at most.
  Vector2d q = p;
  constexpr int kMaxPushes = 4;
  for (int push = 0; push < kMaxPushes; ++push) {
    std::size_t worst = zones.size();
    double worst_d = c;
    for (std::size_t j : zones.near(q, c)) {
      const double d = zones.point_distance(q, j);
      if (d < worst_d) worst = j, worst_d = d;
    }
    if (worst == zones.size()) break;
    ContourPoint cp;
    Vector2d n;
    if (!outward(zones, worst, q, cp, n)) {
      e.ok = false;
      e.why = fmt::format("no outward direction from zone {} at ({:.3f}, {:.3f})", worst, q.x(), q.y());
      return e;
    }
    // A hair beyond the band so that rounding cannot leave the point a nanometre inside it.
    q = cp.point + n * (c * (1.0 + 1e-9) + 1e-6);
  }
  e.point = q;
  if (!zones.point_clear(q)) {
    e.ok = false;
    e.why = fmt::format("no clear point near ({:.3f}, {:.3f}): the nearby zones' bands overlap", p.x(), p.y());
  } else if (!bounds.contains(q)) {
    e.ok = false;
    e.why = fmt::format("the way out of the zone band from ({:.3f}, {:.3f}) leaves the travel box", p.x(), p.y());
  } else if (!zones.segment_clear(p, q, relaxed)) {
    e.ok = false;
    e.why = fmt::format("the way out of the zone band from ({:.3f}, {:.3f}) passes too near another zone", p.x(),
                        p.y());
  }
  return e;
}

// ---------------------------------------------------------------------------------------
// OMPL glue: exact validity, seeded sampling charged to the termination, seeded planner and
// simplifier.

Vector2d to_vec(const ob::State* s) {
  const auto* r = s->as<ob::RealVectorStateSpace::StateType>();
  return {r->values[0], r->values[1]};
}

class ZoneValidityChecker : public ob::StateValidityChecker {
 public:
  ZoneValidityChecker(const ob::SpaceInformationPtr& si, const ZoneSet& zones)
      : ob::StateValidityChecker(si), zones_(zones) {}
  bool isValid(const ob::State* s) const override { return si_->satisfiesBounds(s) && zones_.point_clear(to_vec(s)); }

 private:
  const ZoneSet& zones_;
};

// Exact motion check: the whole segment, not samples of it.
class ExactMotionValidator : public ob::MotionValidator {
 public:
  ExactMotionValidator(const ob::SpaceInformationPtr& si, const ZoneSet& zones)
      : ob::MotionValidator(si), zones_(zones) {}

  bool checkMotion(const ob::State* s1, const ob::State* s2) const override {
    const bool ok = si_->satisfiesBounds(s2) && zones_.segment_clear(to_vec(s1), to_vec(s2));
    ok ? ++valid_ : ++invalid_;
    return ok;
  }

  // The clear prefix of a blocked motion, found by bisection on its length (a prefix of a
  // clear segment is clear, so the test is monotone). lastValid.second is the fraction.
  bool checkMotion(const ob::State* s1, const ob::State* s2, std::pair<ob::State*, double>& lastValid) const override {
    if (checkMotion(s1, s2)) return true;
    const Vector2d a = to_vec(s1), b = to_vec(s2);
    double lo = 0.0, hi = 1.0;
    for (int k = 0; k < 50 && (hi - lo) * (b - a).norm() > 1e-6; ++k) {
      const double mid = 0.5 * (lo + hi);
      (zones_.segment_clear(a, a + mid * (b - a)) ? lo : hi) = mid;
    }
    lastValid.second = lo;
    if (lastValid.first) si_->getStateSpace()->interpolate(s1, s2, lo, lastValid.first);
    return false;
  }

 private:
  const ZoneSet& zones_;
};

// The uniform sampler with a local seed; charges every sample to the rapid's termination.
class SeededSampler : public ob::RealVectorStateSampler {
 public:
  SeededSampler(const ob::StateSpace* space, std::uint32_t seed, Termination& work)
      : ob::RealVectorStateSampler(space), work_(work) {
    rng_.setLocalSeed(seed);
  }
  void sampleUniform(ob::State* s) override {
    work_.charge(1, kSampleWorkS);
    ob::RealVectorStateSampler::sampleUniform(s);
  }

 private:
  Termination& work_;
};

class SeededRRTConnect : public og::RRTConnect {
 public:
  SeededRRTConnect(const ob::SpaceInformationPtr& si, std::uint32_t seed) : og::RRTConnect(si) {
    rng_.setLocalSeed(seed);
  }
};

class SeededSimplifier : public og::PathSimplifier {
 public:
  SeededSimplifier(const ob::SpaceInformationPtr& si, std::uint32_t seed) : og::PathSimplifier(si) {
    rng_.setLocalSeed(seed);
  }
};

Polyline to_polyline(const og::PathGeometric& path) {
  Polyline out;
  for (std::size_t i = 0; i < path.getStateCount(); ++i) out.push_back(to_vec(path.getState(i)));
  return out;
}

// ---------------------------------------------------------------------------------------
// Step 4, our part: deterministic tightening with the exact checks.

// Greedy string pulling: from each kept vertex jump to the farthest later vertex in sight.
Polyline pull_string(const Polyline& p, const ZoneSet& zones) {
  if (p.size() <= 2) return p;
  Polyline out{p.front()};
  std::size_t i = 0;
  while (i + 1 < p.size()) {
    std::size_t j = p.size() - 1;
    while (j > i + 1 && !zones.segment_clear(p[i], p[j])) --j;
    out.push_back(p[j]);
    i = j;
  }
  return out;
}

// Moves each interior vertex towards the foot of its perpendicular on the chord of its
// neighbours, as far as bisection finds both adjacent segments clear. Returns the length
// gained.
double tighten_vertices(Polyline& p, const ZoneSet& zones) {
  const double before = path_length(p);
  for (std::size_t i = 1; i + 1 < p.size(); ++i) {
    const Vector2d a = p[i - 1], v = p[i], b = p[i + 1];
    const Vector2d target = closest_point_on_segment(a, b, v);
    const auto clear_at = [&](double t) {
      const Vector2d q = v + t * (target - v);
      return zones.segment_clear(a, q) && zones.segment_clear(q, b);
    };
    if (clear_at(1.0)) {
      p[i] = target;
      continue;
    }
    double lo = 0.0, hi = 1.0;
    for (int k = 0; k < 40 && (hi - lo) * (target - v).norm() > 1e-7; ++k) {
      const double mid = 0.5 * (lo + hi);
      (clear_at(mid) ? lo : hi) = mid;
    }
    p[i] = v + lo * (target - v);
  }
  return before - path_length(p);
}

// Drops vertices that lie within tol_mm of the chord of their neighbours when the chord is
// clear.
Polyline drop_collinear(const Polyline& p, const ZoneSet& zones, double tol_mm) {
  if (p.size() <= 2) return p;
  Polyline out{p.front()};
  for (std::size_t i = 1; i + 1 < p.size(); ++i) {
    const Vector2d& a = out.back();
    if (point_segment_distance(p[i], a, p[i + 1]) <= tol_mm && zones.segment_clear(a, p[i + 1])) continue;
    out.push_back(p[i]);
  }
  out.push_back(p.back());
  return out;
}

Polyline shorten(const ZoneSet& zones, og::PathSimplifier& simplifier, og::PathGeometric& path) {
  simplifier.reduceVertices(path);
  simplifier.shortcutPath(path, 200, 50);
  Polyline p = pull_string(to_polyline(path), zones);
  for (int round = 0; round < 30; ++round) {
    const double gained = tighten_vertices(p, zones);
    p = pull_string(p, zones);
    p = drop_collinear(p, zones, 1e-6);
    if (gained < 1e-6) break;
  }
  return p;
}

void set_quiet_ompl() {
  static std::once_flag once;
  std::call_once(once, [] { ompl::msg::setLogLevel(ompl::msg::LOG_ERROR); });
}

// ---------------------------------------------------------------------------------------
// Steps 3 to 5 on OMPL.

// The space, its validity checks and the seeded sampler charging `work`.
struct Space {
  std::shared_ptr<ob::RealVectorStateSpace> space;
  ob::SpaceInformationPtr si;
  int attempt = 0;  // the attempt whose seed the next sampler takes
};

Space make_space(const ZoneSet& zones, const Eigen::AlignedBox2d& bounds, std::uint32_t seed, Termination& work) {
  set_quiet_ompl();
  Space s;
  s.space = std::make_shared<ob::RealVectorStateSpace>(2);
  ob::RealVectorBounds rb(2);
  rb.setLow(0, bounds.min().x());
  rb.setLow(1, bounds.min().y());
  rb.setHigh(0, bounds.max().x());
  rb.setHigh(1, bounds.max().y());
  s.space->setBounds(rb);
  int* attempt = &s.attempt;
  s.space->setStateSamplerAllocator([seed, attempt, &work](const ob::StateSpace* sp) -> ob::StateSamplerPtr {
    return std::make_shared<SeededSampler>(sp, derive_seed(seed, *attempt, 1), work);
  });
  s.si = std::make_shared<ob::SpaceInformation>(s.space);
  s.si->setStateValidityChecker(std::make_shared<ZoneValidityChecker>(s.si, zones));
  s.si->setMotionValidator(std::make_shared<ExactMotionValidator>(s.si, zones));
  s.si->setup();
  return s;
}

struct Search {
  Polyline best;  // empty: none found
  int found = 0;  // attempts that found a path
};

// Step 3 and 4: the attempts, each shortened; the shortest wins.
Search search(const Vector2d& a, const Vector2d& b, const ZoneSet& zones, Space& sp, const RapidOptions& options,
              Termination& work) {
  const ob::PlannerTerminationCondition ptc([&work] { return work.should_end(); });
  Search out;
  double best_len = kInf;
  for (int attempt = 0; attempt < options.attempts && !ptc(); ++attempt) {
    sp.attempt = attempt;
    auto pdef = std::make_shared<ob::ProblemDefinition>(sp.si);
    ob::ScopedState<ob::RealVectorStateSpace> s0(sp.space), s1(sp.space);
    s0[0] = a.x(), s0[1] = a.y(), s1[0] = b.x(), s1[1] = b.y();
    pdef->setStartAndGoalStates(s0, s1);
    auto planner = std::make_shared<SeededRRTConnect>(sp.si, derive_seed(options.seed, attempt, 2));
    planner->setProblemDefinition(pdef);
    planner->setNearestNeighbors<ompl::NearestNeighborsLinear>();
    if (planner->solve(ptc) != ob::PlannerStatus::EXACT_SOLUTION) continue;
    auto* path = pdef->getSolutionPath()->as<og::PathGeometric>();
    Polyline raw = to_polyline(*path);
    raw.front() = a, raw.back() = b;  // the planner copies them; keep them bit-exact
    Polyline p = raw;
    if (options.simplify) {
      SeededSimplifier simplifier(sp.si, derive_seed(options.seed, attempt, 3));
      p = shorten(zones, simplifier, *path);
      p.front() = a, p.back() = b;
    }
    if (!zones.polyline_clear(p)) p = raw;  // cannot happen; never return an unchecked path
    if (!zones.polyline_clear(p)) continue;
    ++out.found;
    const double len = path_length(p);
    if (len < best_len) out.best = std::move(p), best_len = len;
  }
  return out;
}

// Step 5: OMPL's B-spline smoothing, checked again; "" or a note when it had to be undone.
std::string smooth(Polyline& best, const ZoneSet& zones, Space& sp, const RapidOptions& options, bool& changed) {
  changed = false;
  if (!options.smooth || best.size() <= 2) return "";
  og::PathGeometric path(sp.si);
  for (const Vector2d& q : best) {
    ob::ScopedState<ob::RealVectorStateSpace> s(sp.space);
    s[0] = q.x(), s[1] = q.y();
    path.append(s.get());
  }
  SeededSimplifier simplifier(sp.si, derive_seed(options.seed, 0, 4));
  simplifier.smoothBSpline(path, 3);
  Polyline smoothed = drop_collinear(to_polyline(path), zones, 0.01);
  smoothed.front() = best.front(), smoothed.back() = best.back();
  if (!zones.polyline_clear(smoothed)) return "; smoothing broke the clearance, unsmoothed path kept";
  changed = smoothed != best;
  best = std::move(smoothed);
  return "";
}

// The travel box: the options' or one round the end points and the zones.
Eigen::AlignedBox2d travel_bounds(const Vector2d& from, const Vector2d& to, const ZoneSet& zones,
                                  const RapidOptions& options) {
  Eigen::AlignedBox2d bounds = options.bounds;
  if (!bounds.isEmpty()) return bounds;
  bounds.extend(from);
  bounds.extend(to);
  for (std::size_t j = 0; j < zones.size(); ++j)
    if (zones.active(j) && !zones.box(j).isEmpty()) bounds.extend(zones.box(j));
  bounds.min().array() -= options.auto_margin_mm + options.clearance_mm;
  bounds.max().array() += options.auto_margin_mm + options.clearance_mm;
  return bounds;
}

}  // namespace

// ---------------------------------------------------------------------------------------

void RapidOptions::validate() const {
  const auto bad = [](const char* field, double v, const char* rule) {
    throw InputError::field(field, fmt::format("is {}, {}", v, rule));
  };
  if (!(clearance_mm > 0.0) || !std::isfinite(clearance_mm)) bad("clearance_mm", clearance_mm, "must be finite and > 0");
  if (!(auto_margin_mm >= 0.0) || !std::isfinite(auto_margin_mm))
    bad("auto_margin_mm", auto_margin_mm, "must be finite and >= 0");
  if (max_samples < 1 || max_samples > 10'000'000) bad("max_samples", max_samples, "must lie in 1 .. 10 000 000");
  if (attempts < 1 || attempts > 100) bad("attempts", attempts, "must lie in 1 .. 100");
  if (!(slug_tip_size_mm >= 0.0) || !std::isfinite(slug_tip_size_mm))
    bad("slug_tip_size_mm", slug_tip_size_mm, "must be finite and >= 0");
  if (!(travel_height_over_cut_mm >= 0.0) || !(travel_height_over_cut_mm <= 1000.0))
    bad("travel_height_over_cut_mm", travel_height_over_cut_mm, "must lie in 0 .. 1000 mm");
  if (!bounds.isEmpty()) {
    if (!bounds.min().allFinite() || !bounds.max().allFinite())
      throw InputError::field("bounds", "the corners of the travel box must be finite");
    if (!(bounds.sizes().minCoeff() > 0.0))
      bad("bounds", bounds.sizes().minCoeff(), "the travel box must have a positive size in x and y");
  }
}

RapidPlan plan_rapid(const Vector2d& from, const Vector2d& to, const std::vector<Contour>& no_go,
                     const RapidOptions& options, Termination& termination, std::size_t first_part_zone) {
  options.validate();
  return plan_rapid(from, to, ZoneSet(no_go, options.clearance_mm), options, termination, first_part_zone);
}

RapidPlan plan_rapid(const Vector2d& from, const Vector2d& to, const ZoneSet& zones, const RapidOptions& options,
                     Termination& termination, std::size_t first_part_zone) {
  options.validate();
  MACHPLAN_ASSERT(zones.clearance() == options.clearance_mm, "zone set clearance {} but options {}", zones.clearance(),
                  options.clearance_mm);
  MACHPLAN_ASSERT(from.allFinite() && to.allFinite(), "plan_rapid: from and to must be finite");
  RapidPlan plan;
  plan.straight_length_mm = (to - from).norm();
  const Eigen::AlignedBox2d bounds = travel_bounds(from, to, zones, options);
  if (!bounds.contains(from) || !bounds.contains(to)) {
    plan.message = fmt::format("({:.3f}, {:.3f}) or ({:.3f}, {:.3f}) lies outside the travel box", from.x(),
                               from.y(), to.x(), to.y());
    return plan;
  }
  // The answer: `inner` between the escape points, with the escape legs added.
  const auto finish = [&](bool straight, Polyline inner, std::string msg) {
    plan.status = Status::done;
    plan.straight = straight;
    plan.min_clearance_mm = zones.polyline_distance(inner);
    if (inner.front() != from) inner.insert(inner.begin(), from);
    if (inner.back() != to) inner.push_back(to);
    plan.polyline = std::move(inner);
    plan.length_mm = path_length(plan.polyline);
    plan.message = std::move(msg);
    return plan;
  };

  // Step 1 and 1b. A rapid that goes nowhere moves nothing, wherever it is.
  plan.straight_blocked = from != to && !zones.segment_clear(from, to);
  if (!plan.straight_blocked) return finish(true, {from, to}, "the straight move is clear");
  if (leaves_directly(from, to, zones, first_part_zone)) {
    plan.straight_blocked = false;
    return finish(true, {from, to}, "straight: leaves or reaches the cut part at its end directly");
  }

  // Step 2.
  const Escape start = escape_from(from, zones, bounds), end = escape_from(to, zones, bounds);
  plan.start_zones = start.relaxed;
  plan.end_zones = end.relaxed;
  if (!start.ok || !end.ok) {
    plan.message = "an end point cannot leave its zones' clearance band: " + (!start.ok ? "start: " + start.why : "end: " + end.why);
    return plan;
  }
  const std::string escape_note =
      (start.relaxed.empty() ? std::string() : fmt::format("; leaves zone(s) {} at the start", fmt::join(start.relaxed, ", "))) +
      (end.relaxed.empty() ? std::string() : fmt::format("; enters zone(s) {} at the end", fmt::join(end.relaxed, ", ")));
  const Vector2d a = start.point, b = end.point;
  if (zones.segment_clear(a, b))
    return finish(false, {a, b}, "straight between the escape legs" + escape_note);

  // Steps 3 and 4, within the rapid's own budget of samples.
  Termination work(termination);
  work.set_budget(options.max_samples, "samples");
  Space sp = make_space(zones, bounds, options.seed, work);
  Search found = search(a, b, zones, sp, options, work);
  plan.samples = static_cast<int>(work.units_spent());
  if (termination.ended()) {
    plan.status = status_of(termination.reason());
    plan.message = fmt::format("ended after {} samples: {}", plan.samples, termination.describe());
    return plan;
  }
  if (found.best.empty()) {
    plan.message = fmt::format("no clear path found in {} samples{}", plan.samples, escape_note);
    return plan;
  }

  // Step 5.
  const std::string smooth_note = smooth(found.best, zones, sp, options, plan.smoothed);
  return finish(false, std::move(found.best),
                fmt::format("planned round the zones ({} of {} attempts found a path, {} samples){}{}", found.found,
                            options.attempts, plan.samples, escape_note, smooth_note));
}

}  // namespace machplan::motion
