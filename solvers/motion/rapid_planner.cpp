#include "solvers/motion/rapid_planner.h"

#include <algorithm>
#include <atomic>
#include <chrono>
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

namespace machplan::motion {
namespace {

namespace ob = ompl::base;
namespace og = ompl::geometric;
using Eigen::Vector2d;
using Polyline = std::vector<Vector2d>;

constexpr double kInf = std::numeric_limits<double>::infinity();

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
// Exact clearance geometry.

// The zones with their spans and bounding boxes, and the exact point and segment tests.
class Zones {
 public:
  Zones(const std::vector<Contour>& zones, double clearance) : clearance_(clearance) {
    for (const Contour& c : zones) {
      Zone z;
      z.contour = &c;
      z.spans = c.segments();
      for (const Segment& s : z.spans) z.span_boxes.push_back(bounding_box(s));
      z.box = bounding_box(c);
      zones_.push_back(std::move(z));
    }
  }

  std::size_t size() const { return zones_.size(); }
  double clearance() const { return clearance_; }

  // Distance from p to the region of zone j (0 inside).
  double point_distance(const Vector2d& p, std::size_t j) const {
    const Zone& z = zones_[j];
    if (z.spans.empty()) return kInf;
    if (contains(*z.contour, p)) return 0.0;
    return distance(*z.contour, p);
  }

  // Distance from segment a -> b to the region of zone j, exact, but only as far as `cap`:
  // any value >= cap may be reported as cap (bounding boxes prune spans that cannot be
  // nearer).
  double segment_distance(const Vector2d& a, const Vector2d& b, std::size_t j, double cap = kInf) const {
    const Zone& z = zones_[j];
    if (z.spans.empty()) return kInf;
    Eigen::AlignedBox2d sb(a);
    sb.extend(b);
    double best = cap;
    if (sb.exteriorDistance(z.box) >= best) return best;
    for (std::size_t i = 0; i < z.spans.size(); ++i) {
      if (sb.exteriorDistance(z.span_boxes[i]) >= best) continue;
      best = std::min(best, segment_distance_mm(a, b, z.spans[i]));
      if (best == 0.0) return 0.0;
    }
    // Apart from the boundary: the segment is wholly inside or wholly outside.
    if (contains(*z.contour, a)) return 0.0;
    return best;
  }

  // `skip[j]` true: zone j is ignored (relaxed). Empty skip: none is.
  bool point_clear(const Vector2d& p, const std::vector<char>& skip = {}) const {
    for (std::size_t j = 0; j < zones_.size(); ++j) {
      if (!skip.empty() && skip[j]) continue;
      if (zones_[j].box.exteriorDistance(p) >= clearance_) continue;
      if (point_distance(p, j) < clearance_) return false;
    }
    return true;
  }

  bool segment_clear(const Vector2d& a, const Vector2d& b, const std::vector<char>& skip = {}) const {
    for (std::size_t j = 0; j < zones_.size(); ++j) {
      if (!skip.empty() && skip[j]) continue;
      if (segment_distance(a, b, j, clearance_) < clearance_) return false;
    }
    return true;
  }

  bool polyline_clear(const Polyline& p) const {
    if (p.size() == 1) return point_clear(p[0]);
    for (std::size_t i = 1; i < p.size(); ++i)
      if (!segment_clear(p[i - 1], p[i])) return false;
    return true;
  }

  double polyline_distance(const Polyline& p) const {
    double best = kInf;
    for (std::size_t j = 0; j < zones_.size(); ++j) {
      if (p.size() == 1) best = std::min(best, point_distance(p[0], j));
      for (std::size_t i = 1; i < p.size(); ++i) best = std::min(best, segment_distance(p[i - 1], p[i], j, best));
    }
    return best;
  }

  const Contour& contour(std::size_t j) const { return *zones_[j].contour; }
  const std::vector<Segment>& spans(std::size_t j) const { return zones_[j].spans; }

 private:
  struct Zone {
    const Contour* contour = nullptr;
    std::vector<Segment> spans;
    std::vector<Eigen::AlignedBox2d> span_boxes;
    Eigen::AlignedBox2d box;
  };
  std::vector<Zone> zones_;
  double clearance_;
};

// ---------------------------------------------------------------------------------------
// Step 2: leaving the clearance band of the zones that hold an end point.

struct Escape {
  bool ok = true;
  Vector2d point = Vector2d::Zero();
  std::vector<std::size_t> relaxed;  // zones whose band held the end point
  std::string why;
};

Escape escape_from(const Vector2d& p, const Zones& zones, const Eigen::AlignedBox2d& bounds) {
  Escape e;
  e.point = p;
  const double c = zones.clearance();
  std::vector<char> relaxed(zones.size(), 0);
  for (std::size_t j = 0; j < zones.size(); ++j)
    if (zones.point_distance(p, j) < c) {
      relaxed[j] = 1;
      e.relaxed.push_back(j);
    }
  if (e.relaxed.empty()) return e;

  // Push out of the most violated band, a few times at most.
  Vector2d q = p;
  constexpr int kMaxPushes = 4;
  for (int push = 0; push < kMaxPushes; ++push) {
    std::size_t worst = zones.size();
    double worst_d = c;
    for (std::size_t j = 0; j < zones.size(); ++j) {
      const double d = zones.point_distance(q, j);
      if (d < worst_d) worst = j, worst_d = d;
    }
    if (worst == zones.size()) break;
    const ContourPoint cp = closest_point(zones.contour(worst), q);
    const bool inside = contains(zones.contour(worst), q);
    Vector2d n;
    if (cp.distance > 1e-9) {
      n = (q - cp.point) / cp.distance;
      if (inside) n = -n;
    } else {
      // On the boundary: the normal of the span, on the side that is not inside.
      const Vector2d t = tangent_at(zones.spans(worst)[cp.span], cp.point);
      n = Vector2d(t.y(), -t.x());
      const bool plus_in = contains(zones.contour(worst), cp.point + c * n);
      const bool minus_in = contains(zones.contour(worst), cp.point - c * n);
      if (plus_in && !minus_in) n = -n;
      else if (plus_in == minus_in && plus_in) {
        e.ok = false;
        e.why = fmt::format("no outward direction from zone {} at ({:.3f}, {:.3f})", worst, q.x(), q.y());
        return e;
      }
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
// OMPL glue: exact validity, seeded sampling, seeded planner and simplifier.

Vector2d to_vec(const ob::State* s) {
  const auto* r = s->as<ob::RealVectorStateSpace::StateType>();
  return {r->values[0], r->values[1]};
}

class ZoneValidityChecker : public ob::StateValidityChecker {
 public:
  ZoneValidityChecker(const ob::SpaceInformationPtr& si, const Zones& zones)
      : ob::StateValidityChecker(si), zones_(zones) {}
  bool isValid(const ob::State* s) const override {
    return si_->satisfiesBounds(s) && zones_.point_clear(to_vec(s));
  }

 private:
  const Zones& zones_;
};

// Exact motion check: the whole segment, not samples of it.
class ExactMotionValidator : public ob::MotionValidator {
 public:
  ExactMotionValidator(const ob::SpaceInformationPtr& si, const Zones& zones)
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
  const Zones& zones_;
};

// The uniform sampler with a local seed; counts every sample for the budget.
class SeededSampler : public ob::RealVectorStateSampler {
 public:
  SeededSampler(const ob::StateSpace* space, std::uint32_t seed, std::atomic<int>* counter)
      : ob::RealVectorStateSampler(space), counter_(counter) {
    rng_.setLocalSeed(seed);
  }
  void sampleUniform(ob::State* s) override {
    ++*counter_;
    ob::RealVectorStateSampler::sampleUniform(s);
  }

 private:
  std::atomic<int>* counter_;
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
Polyline pull_string(const Polyline& p, const Zones& zones) {
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
double tighten_vertices(Polyline& p, const Zones& zones) {
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
Polyline drop_collinear(const Polyline& p, const Zones& zones, double tol_mm) {
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

Polyline shorten(const Zones& zones, og::PathSimplifier& simplifier, og::PathGeometric& path) {
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

}  // namespace

// ---------------------------------------------------------------------------------------
// Public geometry.

// Completeness of the candidates for a line L = [a, b] and an arc A (centre c, radius r):
// d(q, A) for a point q is the least of |q - A.start|, |q - A.end| and, when the direction
// of q - c lies in A's angular range, ||q - c| - r|. Minimising the first two over L gives the
// distances of A's end points to L. For the third, the part of L inside the angular wedge is
// a union of intervals; on each, ||q - c| - r| is either 0 where L crosses the circle (a
// crossing candidate), or convex with its minimum at the foot of c on L (the foot
// candidate), or concave with its minimum at an interval end. Interval ends are end points
// of L (candidates) or points on the wedge's boundary rays, where the value equals the
// distance to an end point of A (covered). Every candidate is d(q, A) for an actual q on L,
// so none is too small.
double segment_distance_mm(const Vector2d& a, const Vector2d& b, const Segment& span) {
  if (!span.is_arc()) {
    const Vector2d &c = span.start, &d = span.end;
    const double o1 = cross(b - a, c - a), o2 = cross(b - a, d - a);
    const double o3 = cross(d - c, a - c), o4 = cross(d - c, b - c);
    if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0))) return 0.0;
    return std::min({point_segment_distance(c, a, b), point_segment_distance(d, a, b), point_segment_distance(a, c, d),
                     point_segment_distance(b, c, d)});
  }
  const auto to_arc = [&](const Vector2d& q) { return (closest_point(span, q) - q).norm(); };
  double best = std::min({to_arc(a), to_arc(b), point_segment_distance(span.start, a, b),
                          point_segment_distance(span.end, a, b)});
  const Vector2d d = b - a;
  const double l2 = d.squaredNorm();
  if (l2 > 0.0) {
    const Vector2d f = a - span.center;
    const double t_foot = std::clamp(-f.dot(d) / l2, 0.0, 1.0);
    best = std::min(best, to_arc(a + t_foot * d));
    // |a + t d - c|^2 = r^2  ->  l2 t^2 + 2 B t + C = 0
    const double B = f.dot(d), C = f.squaredNorm() - span.radius * span.radius;
    const double disc = B * B - l2 * C;
    if (disc >= 0.0) {
      const double root = std::sqrt(disc);
      for (double t : {(-B - root) / l2, (-B + root) / l2})
        if (t >= 0.0 && t <= 1.0) best = std::min(best, to_arc(a + t * d));
    }
  }
  return best;
}

double region_distance_mm(const Vector2d& a, const Vector2d& b, const Contour& zone) {
  if (zone.empty()) return kInf;
  double best = kInf;
  for (const Segment& s : zone.segments()) best = std::min(best, segment_distance_mm(a, b, s));
  if (best > 0.0 && contains(zone, a)) return 0.0;
  return best;
}

double polyline_clearance_mm(const Polyline& polyline, const std::vector<Contour>& zones) {
  double best = kInf;
  for (const Contour& z : zones) {
    if (z.empty()) continue;
    if (polyline.size() == 1) best = std::min(best, contains(z, polyline[0]) ? 0.0 : distance(z, polyline[0]));
    for (std::size_t i = 1; i < polyline.size(); ++i)
      best = std::min(best, region_distance_mm(polyline[i - 1], polyline[i], z));
  }
  return best;
}

const char* to_string(RapidStatus s) {
  switch (s) {
    case RapidStatus::straight: return "straight";
    case RapidStatus::planned: return "planned";
    case RapidStatus::no_path: return "no_path";
    case RapidStatus::endpoint_blocked: return "endpoint_blocked";
    case RapidStatus::out_of_bounds: return "out_of_bounds";
    case RapidStatus::cancelled: return "cancelled";
  }
  return "?";
}

void RapidOptions::validate() const {
  const auto bad = [](const char* field, double v, const char* rule) { require_field(false, field, v, rule); };
  if (!(clearance_mm > 0.0) || !std::isfinite(clearance_mm)) bad("clearance_mm", clearance_mm, "must be finite and > 0");
  if (!(auto_margin_mm >= 0.0) || !std::isfinite(auto_margin_mm))
    bad("auto_margin_mm", auto_margin_mm, "must be finite and >= 0");
  if (max_samples < 1) bad("max_samples", max_samples, "must be >= 1");
  if (!(max_time_s > 0.0) || !std::isfinite(max_time_s)) bad("max_time_s", max_time_s, "must be finite and > 0");
  if (attempts < 1) bad("attempts", attempts, "must be >= 1");
  if (!(slug_tip_size_mm >= 0.0) || !std::isfinite(slug_tip_size_mm))
    bad("slug_tip_size_mm", slug_tip_size_mm, "must be finite and >= 0");
  if (!bounds.isEmpty()) {
    if (!bounds.min().allFinite() || !bounds.max().allFinite())
      throw InputError::field("bounds", "corners must be finite");
    if (!(bounds.sizes().minCoeff() > 0.0))
      bad("bounds", bounds.sizes().minCoeff(), "is the smallest side: the box must have a positive size in x and y");
  }
}

// Step 1b: the straight move leaves the cut part it starts at (or reaches the one it ends at)
// directly. See the file comment of rapid_planner.h.
bool leaves_directly(const Vector2d& from, const Vector2d& to, const Zones& zones, std::size_t first_part) {
  const double c = zones.clearance();
  const double len = (to - from).norm();
  if (!(len > 0.0)) return false;
  const Vector2d u = (to - from) / len;
  std::vector<char> at_start(zones.size(), 0), at_end(zones.size(), 0);
  bool any = false;
  for (std::size_t j = 0; j < zones.size(); ++j) {
    at_start[j] = zones.point_distance(from, j) < c;
    at_end[j] = zones.point_distance(to, j) < c;
    if ((at_start[j] || at_end[j]) && j < first_part) return false;  // a declared zone: never relaxed
    any = any || at_start[j] || at_end[j];
  }
  if (!any) return false;
  const double near = std::min(2.0 * c, 0.5 * len);
  const double eps = 1e-6 * std::max(1.0, len);
  const Vector2d p1 = from + near * u, p2 = to - near * u;
  for (std::size_t j = 0; j < zones.size(); ++j) {
    // The middle keeps the full clearance from every zone.
    if (len > 2.0 * near && zones.segment_distance(p1, p2, j, c) < c) return false;
    // Each end leg keeps it from the zones not at its end, and does not enter those at its end.
    const double d_start = zones.segment_distance(from + eps * u, p1, j, c);
    if (at_start[j] ? !(d_start > 0.0) : d_start < c) return false;
    const double d_end = zones.segment_distance(p2, to - eps * u, j, c);
    if (at_end[j] ? !(d_end > 0.0) : d_end < c) return false;
  }
  return true;
}

RapidPlan plan_rapid(const Vector2d& from, const Vector2d& to, const std::vector<Contour>& no_go,
                     const RapidOptions& options, std::size_t first_part_zone) {
  options.validate();
  MACHPLAN_ASSERT(from.allFinite() && to.allFinite(), "plan_rapid: from and to must be finite");
  RapidPlan plan;
  plan.straight_length_mm = (to - from).norm();
  const Zones zones(no_go, options.clearance_mm);
  const double c = options.clearance_mm;

  Eigen::AlignedBox2d bounds = options.bounds;
  if (bounds.isEmpty()) {
    bounds.extend(from);
    bounds.extend(to);
    for (const Contour& z : no_go)
      if (!z.empty()) bounds.extend(bounding_box(z));
    bounds.min().array() -= options.auto_margin_mm + c;
    bounds.max().array() += options.auto_margin_mm + c;
  }
  if (!bounds.contains(from) || !bounds.contains(to)) {
    plan.status = RapidStatus::out_of_bounds;
    plan.message = fmt::format("({:.3f}, {:.3f}) or ({:.3f}, {:.3f}) lies outside the travel box", from.x(),
                               from.y(), to.x(), to.y());
    return plan;
  }

  // A rapid that goes nowhere moves nothing, wherever it is.
  plan.straight_blocked = from != to && !zones.segment_clear(from, to);
  const auto finish = [&](RapidStatus status, Polyline inner, const Escape& s, const Escape& e, std::string msg) {
    plan.status = status;
    plan.min_clearance_mm = zones.polyline_distance(inner);
    if (s.point != from) inner.insert(inner.begin(), from);
    if (e.point != to) inner.push_back(to);
    plan.polyline = std::move(inner);
    plan.length_mm = path_length(plan.polyline);
    plan.message = std::move(msg);
    return plan;
  };
  if (!plan.straight_blocked) {
    Escape none;
    none.point = from;
    Escape none_end;
    none_end.point = to;
    return finish(RapidStatus::straight, {from, to}, none, none_end, "the straight move is clear");
  }
  if (leaves_directly(from, to, zones, first_part_zone)) {
    Escape none;
    none.point = from;
    Escape none_end;
    none_end.point = to;
    plan.straight_blocked = false;
    return finish(RapidStatus::straight, {from, to}, none, none_end,
                  "straight: leaves or reaches the cut part at its end directly");
  }

  // Step 2.
  const Escape start = escape_from(from, zones, bounds);
  const Escape end = escape_from(to, zones, bounds);
  plan.start_zones = start.relaxed;
  plan.end_zones = end.relaxed;
  if (!start.ok || !end.ok) {
    plan.status = RapidStatus::endpoint_blocked;
    plan.min_clearance_mm = 0.0;
    plan.message = !start.ok ? "start: " + start.why : "end: " + end.why;
    return plan;
  }
  const std::string escape_note =
      (start.relaxed.empty() ? std::string() : fmt::format("; leaves zone(s) {} at the start", fmt::join(start.relaxed, ", "))) +
      (end.relaxed.empty() ? std::string() : fmt::format("; enters zone(s) {} at the end", fmt::join(end.relaxed, ", ")));
  const Vector2d a = start.point, b = end.point;
  if (zones.segment_clear(a, b))
    return finish(RapidStatus::planned, {a, b}, start, end, "straight between the escape legs" + escape_note);

  // Step 3.
  set_quiet_ompl();
  auto space = std::make_shared<ob::RealVectorStateSpace>(2);
  ob::RealVectorBounds rb(2);
  rb.setLow(0, bounds.min().x());
  rb.setLow(1, bounds.min().y());
  rb.setHigh(0, bounds.max().x());
  rb.setHigh(1, bounds.max().y());
  space->setBounds(rb);
  std::atomic<int> samples{0};
  int attempt_now = 0;
  space->setStateSamplerAllocator([&](const ob::StateSpace* s) -> ob::StateSamplerPtr {
    return std::make_shared<SeededSampler>(s, derive_seed(options.seed, attempt_now, 1), &samples);
  });
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setStateValidityChecker(std::make_shared<ZoneValidityChecker>(si, zones));
  si->setMotionValidator(std::make_shared<ExactMotionValidator>(si, zones));
  si->setup();

  const auto t0 = std::chrono::steady_clock::now();
  bool timed_out = false;
  bool cancelled = false;
  const ob::PlannerTerminationCondition ptc([&] {
    if (samples.load() >= options.max_samples) return true;
    if (options.stop.stop_requested()) return cancelled = true;
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > options.max_time_s)
      return timed_out = true;
    return false;
  });

  Polyline best;
  double best_len = kInf;
  int found = 0;
  for (int attempt = 0; attempt < options.attempts && !ptc(); ++attempt) {
    attempt_now = attempt;
    auto pdef = std::make_shared<ob::ProblemDefinition>(si);
    ob::ScopedState<ob::RealVectorStateSpace> s0(space), s1(space);
    s0[0] = a.x(), s0[1] = a.y(), s1[0] = b.x(), s1[1] = b.y();
    pdef->setStartAndGoalStates(s0, s1);
    auto planner = std::make_shared<SeededRRTConnect>(si, derive_seed(options.seed, attempt, 2));
    planner->setProblemDefinition(pdef);
    planner->setNearestNeighbors<ompl::NearestNeighborsLinear>();
    const ob::PlannerStatus st = planner->solve(ptc);
    if (st != ob::PlannerStatus::EXACT_SOLUTION) continue;
    auto* path = pdef->getSolutionPath()->as<og::PathGeometric>();
    Polyline raw = to_polyline(*path);
    raw.front() = a, raw.back() = b;  // the planner copies them; keep them bit-exact
    Polyline p = raw;
    if (options.simplify) {
      SeededSimplifier simplifier(si, derive_seed(options.seed, attempt, 3));
      p = shorten(zones, simplifier, *path);
      p.front() = a, p.back() = b;
    }
    if (!zones.polyline_clear(p)) p = raw;  // cannot happen; never return an unchecked path
    if (!zones.polyline_clear(p)) continue;
    ++found;
    const double len = path_length(p);
    if (len < best_len) best = std::move(p), best_len = len;
  }
  plan.samples = samples.load();
  if (cancelled) {
    plan.status = RapidStatus::cancelled;
    plan.polyline.clear();
    plan.min_clearance_mm = 0.0;
    plan.message = fmt::format("stopped on request after {} samples", plan.samples);
    return plan;
  }
  if (best.empty()) {
    plan.status = RapidStatus::no_path;
    plan.min_clearance_mm = 0.0;
    plan.message = fmt::format("no clear path found in {} samples{}{}", plan.samples,
                               timed_out ? fmt::format(" (stopped by the {:.3g} s time limit)", options.max_time_s) : "",
                               escape_note);
    return plan;
  }

  // Step 5.
  std::string smooth_note;
  if (options.smooth && best.size() > 2) {
    og::PathGeometric path(si);
    for (const Vector2d& q : best) {
      ob::ScopedState<ob::RealVectorStateSpace> s(space);
      s[0] = q.x(), s[1] = q.y();
      path.append(s.get());
    }
    SeededSimplifier simplifier(si, derive_seed(options.seed, 0, 4));
    simplifier.smoothBSpline(path, 3);
    Polyline smooth = drop_collinear(to_polyline(path), zones, 0.01);
    smooth.front() = a, smooth.back() = b;
    if (zones.polyline_clear(smooth)) {
      plan.smoothed = smooth != best;
      best = std::move(smooth);
    } else {
      smooth_note = "; smoothing broke the clearance, unsmoothed path kept";
    }
  }
  return finish(RapidStatus::planned, std::move(best), start, end,
                fmt::format("planned round the zones ({} of {} attempts found a path, {} samples{}){}{}", found,
                            options.attempts, plan.samples, timed_out ? ", time limit reached" : "", escape_note,
                            smooth_note));
}

}  // namespace machplan::motion
