#include "solvers/placement/search/search.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <chrono>
#include <charconv>
#include <cmath>
#include <limits>
#include <memory>
#include <queue>
#include <set>
#include <tuple>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "engine/common/error.h"
#include "engine/common/internal/parse.h"
#include "solvers/placement/report/internal/report.h"
#include "solvers/placement/search/internal/job_axes.h"
#include "solvers/placement/search/internal/objective.h"
#include "solvers/placement/search/internal/planned_time.h"

namespace machplan::placement {

namespace {

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// An angle in (-180, 180].
double normalized_deg(double a) {
  double r = std::remainder(a, 360.0);
  if (r <= -180.0) r += 360.0;
  return r;
}

bool on_region(const Eigen::AlignedBox2d& r, double x, double y) {
  return x >= r.min().x() - 1e-9 && x <= r.max().x() + 1e-9 && y >= r.min().y() - 1e-9 && y <= r.max().y() + 1e-9;
}

std::string unavoidable_message(const Finding& c1) {
  return fmt::format("class-1 interference ({} at tool-path index {}, clearance {:.2f} mm) cannot be avoided by relocation",
                     c1.what, c1.pose, c1.clearance_mm);
}

// ---------------------------------------------------------------- the paper's evasion search

PlacementResult paper_search(const Scene& scene, Checker& checker, Termination& term) {
  PlacementResult res;
  const SearchSettings& ss = scene.search;
  res.region = placement_region(scene, 0.0);
  const Finding& c1 = checker.class1(0.0, term);
  if (c1.interferes) {
    res.summary.status = Status::infeasible;
    res.summary.message = unavoidable_message(c1);
    res.report = checker.report({}, term);
    return res;
  }
  Placement p;
  p.pad_mm = scene.pad_min_mm();
  Eigen::Vector2d prev = Eigen::Vector2d::Zero();
  bool have_prev = false;
  std::set<std::tuple<long, long, long>> seen;
  Finding w;
  for (int step = 0; step < ss.paper_max_steps; ++step) {
    if (term.should_end()) throw WorkEnded{term.reason()};
    res.trail.push_back(p);
    ++res.placements_examined;
    if (checker.decide(p, {}, term, &w, nullptr, /*peripherals_first=*/true) == Decision::feasible) {
      res.summary.status = Status::done;
      res.placement = p;
      res.summary.message = fmt::format("free after {} steps", step);
      break;
    }
    const Eigen::Vector2d dir = w.evasion;
    const bool reverse =
        have_prev && dir.norm() > 0 && std::acos(std::clamp(dir.dot(prev), -1.0, 1.0)) > ss.reversal_deg * kDeg;
    Placement next = p;
    next.x_mm += ss.paper_step_mm * dir.x();
    next.y_mm += ss.paper_step_mm * dir.y();
    const auto key = std::make_tuple(std::lround(next.x_mm * 100), std::lround(next.y_mm * 100), std::lround(p.pad_mm * 100));
    if (reverse || dir.norm() == 0 || !on_region(res.region, next.x_mm, next.y_mm) || seen.count(key)) {
      p.pad_mm += ss.paper_pad_step_mm;
      have_prev = false;
      if (p.pad_mm > ss.pad_max_mm + 1e-9) {
        res.summary.status = Status::infeasible;
        res.summary.message = fmt::format("the search reached the highest pad ({:.0f} mm) without a free placement; last "
                                          "interference: {}",
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
      res.summary.status = Status::budget;
      res.summary.message = fmt::format("gave up after {} steps", ss.paper_max_steps);
    }
  }
  res.report = checker.report(res.summary.done() ? res.placement : p, term);
  return res;
}

// ---------------------------------------------------------------- the certified optimum

// The rotations a search may choose from, sorted by angle in (-180, 180].
struct Rotations {
  std::vector<double> deg;    // normalized
  std::vector<double> shown;  // as asked

  // The member of [r0, r1] nearest 0 (ties: the positive one).
  int best(int r0, int r1) const {
    const auto it = std::lower_bound(deg.begin() + r0, deg.begin() + r1 + 1, 0.0);
    int k = static_cast<int>(it - deg.begin());
    if (k > r1) return r1;
    if (k > r0 && -deg[k - 1] < deg[k]) return k - 1;
    return k;
  }
};

// The order of placements: objective first, then the lowest pad, then nearest the table
// centre, then the smallest turn (positive before negative), then x, then y. Total, so the answer never depends on the
// order work was done in.
struct Key {
  double primary = 0;  // the pad (lowest), or the travel or time objective's bound
  long pad = 0;        // then the lowest pad (fixture) ...
  double dist2 = 0, turn = 0;
  int negative = 0;
  long x = 0, y = 0;
  bool operator<(const Key& o) const {
    return std::tie(primary, pad, dist2, turn, negative, x, y) <
           std::tie(o.primary, o.pad, o.dist2, o.turn, o.negative, o.x, o.y);
  }
};

struct Box {
  long x0, x1, y0, y1, p0, p1;  // grid indices, inclusive
  int r0, r1;                   // rotation indices, inclusive
  Key key;
  std::uint64_t settled = 0;    // known interferences shown absent over the box
  bool point() const { return x0 == x1 && y0 == y1 && p0 == p1 && r0 == r1; }
  double volume() const { return double(x1 - x0 + 1) * (y1 - y0 + 1) * (p1 - p0 + 1) * (r1 - r0 + 1); }
  bool operator>(const Box& o) const { return o.key < key; }
};

long nearest_to_zero(long a, long b) { return std::clamp(0L, a, b); }

struct Learned {
  Spot spot;
  int id;
};

// What screening found for one box (computed in parallel, applied in order).
struct Screened {
  Decision decision = Decision::unknown;
  std::uint64_t settled = 0;
  int killer = -1;              // learned interference (by id) that condemned the box
  std::vector<Box> children;    // the box split (or lifted), when undecided
  double condemned = 0.0;       // volume condemned by a lift
  double planned_s = 0.0;       // time: the feed planner's time at a single placement left free
};

// Time: the feed planner times at most this many placements once one is certified.
constexpr long kMaxTimed = 100;

class OptimalSearch {
 public:
  OptimalSearch(const Scene& scene, Checker& checker, PlacementOptions::Objective objective, Rotations rotations,
                int threads, double time_gap_pct, Termination& term, Progress* progress)
      : scene_(scene), checker_(checker), objective_(objective), rot_(std::move(rotations)), term_(term),
        progress_(progress), g_(scene.search.resolution_mm), pad0_(scene.pad_min_mm()), threads_(threads),
        batch_(threads > 1 ? 8 * threads : 1), time_keep_(1.0 - time_gap_pct / 100.0) {
    for (const auto& t : scene.tips_mm) radius_ = std::max(radius_, t.head<2>().norm());
    // A turn moves the machine's parts about as far as the tips' distance from the axis plus the
    // tool assembly's reach: that is how long a rotation side is, against x, y and pad.
    double reach = 0;
    for (const SceneTool& t : scene.tools) reach = std::max(reach, t.model->assembly_reach_mm());
    radius_ += reach;
  }

  PlacementResult run();

 private:
  bool lexicographic() const { return objective_ == PlacementOptions::Objective::lowest; }
  bool timed() const { return objective_ == PlacementOptions::Objective::time; }
  bool best_timed_set() const { return best_time_s_ < std::numeric_limits<double>::infinity(); }
  // Time: what a box's bound must stay below to be searched, the best planned time less the gap.
  double time_cutoff() const { return best_time_s_ * time_keep_; }
  // Time: the lowest bound left is no less than the cutoff, or the planner has timed kMaxTimed
  // placements and one of them is certified.
  bool time_settled() const {
    return timed() && best_timed_set() && (timed_ >= kMaxTimed || (!open_.empty() && open_.top().key.primary >= time_cutoff()));
  }
  // Time: the lowest placement, found by a quick search of its own and timed, is the first best.
  void time_lowest_first(PlacementResult& res);
  Placement at(long x, long y, long p, int r) const {
    return {x * g_, y * g_, pad0_ + p * g_, rot_.shown[r]};
  }
  Placement best_point(const Box& b) const {
    return at(nearest_to_zero(b.x0, b.x1), nearest_to_zero(b.y0, b.y1), b.p0, rot_.best(b.r0, b.r1));
  }
  Placement centre(const Box& b, Ball* ball) const {
    const double mid = (rot_.deg[b.r0] + rot_.deg[b.r1]) / 2;
    ball->radius_mm = 0.5 * g_ *
                      std::sqrt(double((b.x1 - b.x0) * (b.x1 - b.x0) + (b.y1 - b.y0) * (b.y1 - b.y0) + (b.p1 - b.p0) * (b.p1 - b.p0)));
    ball->turn_deg = (rot_.deg[b.r1] - rot_.deg[b.r0]) / 2;
    ball->pad_half_mm = 0.5 * g_ * double(b.p1 - b.p0);
    ball->x_half_mm = 0.5 * g_ * double(b.x1 - b.x0);
    ball->y_half_mm = 0.5 * g_ * double(b.y1 - b.y0);
    return {(b.x0 + b.x1) * 0.5 * g_, (b.y0 + b.y1) * 0.5 * g_, pad0_ + (b.p0 + b.p1) * 0.5 * g_,
            b.r0 == b.r1 ? rot_.shown[b.r0] : mid};
  }
  Key key_of(const Box& b) const;
  Box make(long x0, long x1, long y0, long y1, long p0, long p1, int r0, int r1, std::uint64_t settled = 0) const {
    Box b{x0, x1, y0, y1, p0, p1, r0, r1, {}, settled};
    b.key = key_of(b);
    return b;
  }
  // Splits the side that narrows the undecided constraints most (`spread`: how much of their
  // range each of x, y and pad makes; zero when not known: then the longest side).
  std::vector<Box> split(const Box& b, std::uint64_t settled, const Eigen::Vector3d& spread = Eigen::Vector3d::Zero()) const;
  Screened screen(const Box& b, const std::vector<Learned>& known);
  // The grid, class 1 and the objective; false when that already settles the search.
  bool prepare(PlacementResult& res);
  // Applies a screened batch in pop order; true once a placement is certified.
  bool merge(std::vector<Box>& batch, std::vector<Screened>& screened, PlacementResult& res);
  // Certifies a box's best point; true when it is free and ends the search (on `time` a free
  // point with the least planned time so far, `planned_s`, becomes the best and the search goes on).
  bool certify(Box& b, PlacementResult& res, double planned_s);
  void learn(const Spot& s);
  bool class1_dead(int r);
  void certify_rotation_interval(PlacementResult& res);
  std::string time_message(const PlacementResult& res) const;

  const Scene& scene_;
  Checker& checker_;
  PlacementOptions::Objective objective_;
  Rotations rot_;
  Termination& term_;
  Progress* progress_;
  double g_, pad0_;
  int threads_;
  std::size_t batch_;
  double time_keep_;  // time: 1 less the gap
  bool bare_ = false;  // the answer alone: no report of it, no rotation interval
  std::vector<Learned> learned_;  // interferences met so far, most recently useful first
  std::vector<std::optional<AxisObjective>> objective_at_;  // per rotation (travel, time)
  std::vector<std::optional<PlannedTime>> planned_at_;     // per rotation (time)
  double best_time_s_ = std::numeric_limits<double>::infinity();  // time: the best certified placement's ...
  Placement best_timed_;                                          // ... planned time, and where
  long timed_ = 0;                                                // placements timed by the planner
  double time_left_bound_s_ = std::numeric_limits<double>::infinity();  // least bound of the boxes left
  std::vector<int> class1_state_;  // per rotation: -1 unknown, 0 clear, 1 interferes
  std::set<std::tuple<long, long, long, int>> rejected_;  // points whose certification failed
  // Candidates refused on a tool change's moves, which teach the search nothing about their
  // neighbours: past kMaxChangeRefusals the search gives up rather than try every point.
  long change_refusals_ = 0;
  static constexpr long kMaxChangeRefusals = 200;
  bool ring_clear_ = true;
  double radius_ = 0.0;  // farthest tip from the workpiece's z axis
  std::priority_queue<Box, std::vector<Box>, std::greater<>> open_;
  double total_volume_ = 1.0, done_volume_ = 0.0;
  Finding last_;  // the last interference a certification met
};

Key OptimalSearch::key_of(const Box& b) const {
  const long nx = nearest_to_zero(b.x0, b.x1), ny = nearest_to_zero(b.y0, b.y1);
  const int r = rot_.best(b.r0, b.r1);
  Key k;
  k.dist2 = double(nx) * nx + double(ny) * ny;
  k.turn = std::abs(rot_.deg[r]);
  k.negative = rot_.deg[r] < 0 ? 1 : 0;
  k.x = nx, k.y = ny;
  k.pad = b.p0;
  if (lexicographic()) {
    k.primary = static_cast<double>(b.p0);
  } else {
    // Travel and time boxes never span rotations (the root boxes are one per rotation).
    const Eigen::Vector3d c((b.x0 + b.x1) * 0.5 * g_, (b.y0 + b.y1) * 0.5 * g_, pad0_ + (b.p0 + b.p1) * 0.5 * g_);
    const Eigen::Vector3d h((b.x1 - b.x0) * 0.5 * g_, (b.y1 - b.y0) * 0.5 * g_, (b.p1 - b.p0) * 0.5 * g_);
    k.primary = 0.0;
    if (const auto& f = objective_at_[b.r0]) k.primary = b.point() ? f->value(c) : f->lower_bound(c, h);
    // Time: the planner's envelope over the box, tighter where accelerations matter (and the
    // only bound on a hexapod, whose sliders are not affine in the placement).
    if (timed()) k.primary = std::max(k.primary, planned_at_[b.r0]->lower_bound(c, h));
  }
  return k;
}

std::vector<Box> OptimalSearch::split(const Box& b, std::uint64_t settled, const Eigen::Vector3d& spread) const {
  // Split the longest side: grid steps, and for rotations the distance the farthest tip moves.
  double sx = b.x1 - b.x0, sy = b.y1 - b.y0, sp = b.p1 - b.p0;
  if (b.r0 == b.r1 && spread.maxCoeff() > 0.0) {
    // At one rotation, by what each side adds to the range (a side one grid step wide or less
    // adds nothing a split could remove).
    sx = sx > 0 ? spread.x() : 0, sy = sy > 0 ? spread.y() : 0, sp = sp > 0 ? spread.z() : 0;
    if (std::max({sx, sy, sp}) <= 0) sx = b.x1 - b.x0, sy = b.y1 - b.y0, sp = b.p1 - b.p0;
  }
  const double turn_mm = (rot_.deg[b.r1] - rot_.deg[b.r0]) * kDeg * radius_ / g_;
  std::vector<Box> out;
  if (b.r1 > b.r0 && turn_mm >= std::max({sx, sy, sp})) {
    const int m = b.r0 + (b.r1 - b.r0) / 2;
    out.push_back(make(b.x0, b.x1, b.y0, b.y1, b.p0, b.p1, b.r0, m, settled));
    out.push_back(make(b.x0, b.x1, b.y0, b.y1, b.p0, b.p1, m + 1, b.r1, settled));
  } else if (sp >= sx && sp >= sy) {
    MACHPLAN_ASSERT(sp > 0, "split of an undecided single placement");
    const long m = b.p0 + (b.p1 - b.p0) / 2;
    out.push_back(make(b.x0, b.x1, b.y0, b.y1, b.p0, m, b.r0, b.r1, settled));
    out.push_back(make(b.x0, b.x1, b.y0, b.y1, m + 1, b.p1, b.r0, b.r1, settled));
  } else if (sx >= sy) {
    const long m = b.x0 + (b.x1 - b.x0) / 2;
    out.push_back(make(b.x0, m, b.y0, b.y1, b.p0, b.p1, b.r0, b.r1, settled));
    out.push_back(make(m + 1, b.x1, b.y0, b.y1, b.p0, b.p1, b.r0, b.r1, settled));
  } else {
    const long m = b.y0 + (b.y1 - b.y0) / 2;
    out.push_back(make(b.x0, b.x1, b.y0, m, b.p0, b.p1, b.r0, b.r1, settled));
    out.push_back(make(b.x0, b.x1, m + 1, b.y1, b.p0, b.p1, b.r0, b.r1, settled));
  }
  return out;
}


Screened OptimalSearch::screen(const Box& b, const std::vector<Learned>& known) {
  Screened out;
  Ball ball;
  const Placement c = centre(b, &ball);
  // Placement-only checks first: on the table, clear of the peripherals.
  Decision d = checker_.decide_block(c, ball);
  if (d == Decision::infeasible) {
    out.decision = d;
    return out;
  }
  bool all_clear = d == Decision::feasible;
  // Class 1 is known per rotation once asked (the merge asks before a certification).
  if (!ring_clear_) {
    if (b.r0 == b.r1 && class1_state_[b.r0] == 1) {
      out.decision = Decision::infeasible;
      return out;
    }
    if (b.r0 != b.r1 || class1_state_[b.r0] != 0) all_clear = false;
  }
  std::uint64_t settled = b.settled;
  const Where where = Where::of(c);
  long lift = b.p0;  // the lowest pad no known interference condemns
  Eigen::Vector3d spread = Eigen::Vector3d::Zero();
  for (const Learned& w : known) {
    const std::uint64_t bit = w.id < 64 ? std::uint64_t{1} << w.id : 0;
    if (settled & bit) continue;
    SpotScreen more;
    const Decision s = checker_.screen_spot(w.spot, where, ball, term_, &more);
    const double below = more.condemned_below_mm;
    if (s == Decision::infeasible) {
      out.decision = Decision::infeasible;
      out.killer = w.id;
      return out;
    }
    if (s == Decision::unknown) {
      all_clear = false;
      if (below / g_ < double(b.p1 - lift)) lift = b.p1 - static_cast<long>(std::floor(below / g_));
      spread += Eigen::Vector3d(more.spread_mm[0], more.spread_mm[1], more.spread_mm[2]);
    } else {
      settled |= bit;
    }
  }
  out.settled = settled;
  if (lift > b.p0) {
    // The pads below `lift` are condemned: the rest of the box is screened again.
    out.decision = Decision::unknown;
    out.condemned = b.volume() * double(lift - b.p0) / double(b.p1 - b.p0 + 1);
    out.children.push_back(make(b.x0, b.x1, b.y0, b.y1, lift, b.p1, b.r0, b.r1, settled));
    return out;
  }
  out.decision = all_clear ? Decision::feasible : Decision::unknown;
  // Undecided, or free of everything known but not a single placement on an objective whose
  // boxes have no best point: split now (the children's bounds are computed here, in
  // parallel).
  if (out.decision == Decision::unknown || (!lexicographic() && !b.point())) {
    out.children = split(b, settled, spread);
  } else if (timed() && b.key.primary < best_time_s_) {
    out.planned_s = planned_at_[b.r0]->planned_s(best_point(b).offset());  // here, in parallel
  }
  return out;
}

void OptimalSearch::learn(const Spot& s) {
  auto same = [&](const Learned& o) { return o.spot.pose == s.pose && o.spot.t == s.t && o.spot.constraint == s.constraint; };
  const auto it = std::find_if(learned_.begin(), learned_.end(), same);
  if (it != learned_.end()) {
    std::rotate(learned_.begin(), it, it + 1);
    return;
  }
  learned_.insert(learned_.begin(), Learned{s, static_cast<int>(learned_.size())});
}

bool OptimalSearch::class1_dead(int r) {
  if (ring_clear_) return false;
  if (class1_state_[r] < 0) class1_state_[r] = checker_.class1(rot_.shown[r], term_).interferes ? 1 : 0;
  return class1_state_[r] == 1;
}

bool OptimalSearch::prepare(PlacementResult& res) {
  res.rotations = static_cast<long>(rot_.deg.size());
  // The grid: x, y where the footprint stays on the table at some rotation; pads from the
  // lowest to the highest.
  Eigen::AlignedBox2d region;
  for (double r : rot_.shown) region.extend(placement_region(scene_, r));
  res.region = region;
  const long x0 = static_cast<long>(std::ceil(region.min().x() / g_ - 1e-9));
  const long x1 = static_cast<long>(std::floor(region.max().x() / g_ + 1e-9));
  const long y0 = static_cast<long>(std::ceil(region.min().y() / g_ - 1e-9));
  const long y1 = static_cast<long>(std::floor(region.max().y() / g_ + 1e-9));
  const long p1 = static_cast<long>(std::floor((scene_.search.pad_max_mm - pad0_) / g_ + 1e-9));
  if (region.isEmpty() || x0 > x1 || y0 > y1 || p1 < 0) {
    res.summary.status = Status::infeasible;
    res.summary.message = p1 < 0 ? "the spoilboard is thicker than the highest pad" : "the workpiece does not fit on the table";
    return false;
  }
  // Class 1 first: an interference no relocation or rotation cures ends the search.
  const int nrot = static_cast<int>(rot_.deg.size());
  class1_state_.assign(nrot, -1);
  const Finding& every = nrot == 1 ? checker_.class1(rot_.shown[0], term_) : checker_.class1_every_rotation(term_);
  ring_clear_ = !every.interferes;
  if (every.interferes && (nrot == 1 || every.what.rfind("plate hinges (any rotation)", 0) != 0)) {
    res.summary.status = Status::infeasible;
    res.summary.message = unavoidable_message(nrot == 1 ? every : checker_.class1(rot_.shown[0], term_));
    res.report = checker_.report(at(0, 0, 0, 0), term_);
    return false;
  }
  if (nrot == 1) class1_state_[0] = 0;
  if (!lexicographic()) {
    const auto kind = objective_ == PlacementOptions::Objective::travel ? AxisObjective::Kind::travel : AxisObjective::Kind::time;
    for (int r = 0; r < nrot; ++r) {
      const auto path = job_axis_path(scene_, rot_.shown[r] * kDeg);
      objective_at_.emplace_back();
      if (!path->on_rails()) objective_at_.back().emplace(*path, kind);
      if (timed()) planned_at_.emplace_back(PlannedTime(std::move(*path)));
    }
  }
  if (lexicographic()) {
    open_.push(make(x0, x1, y0, y1, 0, p1, 0, nrot - 1));
  } else {
    for (int r = 0; r < nrot; ++r) open_.push(make(x0, x1, y0, y1, 0, p1, r, r));
  }
  total_volume_ = double(x1 - x0 + 1) * (y1 - y0 + 1) * (p1 + 1) * nrot;
  return true;
}

bool OptimalSearch::certify(Box& b, PlacementResult& res, double planned_s) {
  // No interference met so far objects anywhere in the box, so its best point is the best
  // candidate left: certify it over the whole path. If that fails, the checker has found the
  // interference, which is learned, and the box is screened again; the point is out for good
  // (should the screening pass the box again, it is split, never certified at the same point).
  const Placement best = best_point(b);
  const int br = rot_.best(b.r0, b.r1);
  const auto point = std::make_tuple(nearest_to_zero(b.x0, b.x1), nearest_to_zero(b.y0, b.y1), b.p0, br);
  if (class1_dead(br)) {
    if (b.r0 == b.r1)
      done_volume_ += b.volume();
    else
      for (Box& c : split(b, 0)) open_.push(std::move(c));  // split the rotations away from the dead one
    return false;
  }
  if (timed() && b.point()) {
    ++timed_;
    if (planned_s >= best_time_s_) {  // cannot beat the best: no need to certify it
      done_volume_ += b.volume();
      return false;
    }
  }
  if (!rejected_.count(point)) {
    ++res.certifications;
    Spot spot;
    if (checker_.probe(best, {}, term_, &spot) == Decision::infeasible) {  // a quick look first
      learn(spot);
      rejected_.insert(point);
      last_ = Finding{};
      last_.what = checker_.constraint_name(spot);
      open_.push(b);
      return false;
    }
    spot = Spot{};
    Finding w;
    if (checker_.decide(best, {}, term_, &w, &spot) == Decision::feasible) {
      if (timed()) {
        best_time_s_ = planned_s;
        best_timed_ = best;
        done_volume_ += b.volume();
        return false;
      }
      res.summary.status = Status::done;
      res.placement = best;
      res.objective_value = lexicographic() ? best.pad_mm : b.key.primary;
      return true;
    }
    last_ = w;
    if (spot.exact) {
      learn(spot);
      rejected_.insert(point);
      open_.push(b);
      return false;
    }
    // Refused without an exact interfering pose (an interval that could not be proven, or a
    // tool change's moves): the point is out, and the rest of the box is split as usual.
    rejected_.insert(point);
    if (spot.tool_change) ++change_refusals_;
  }
  if (!b.point())
    for (Box& c : split(b, b.settled)) open_.push(std::move(c));
  return false;
}

bool OptimalSearch::merge(std::vector<Box>& batch, std::vector<Screened>& screened, PlacementResult& res) {
  // In pop order: only a box with nothing smaller left may be certified.
  bool blocked = false;
  for (std::size_t k = 0; k < batch.size(); ++k) {
    Box& b = batch[k];
    Screened& s = screened[k];
    if (s.decision == Decision::infeasible || (timed() && b.key.primary >= time_cutoff())) {
      // A box left for its bound may hold faster placements than the best (by less than the
      // gap): its bound stays part of the bound the report gives.
      if (s.decision != Decision::infeasible) time_left_bound_s_ = std::min(time_left_bound_s_, b.key.primary);
      done_volume_ += b.volume();
      report_progress(progress_, done_volume_ / total_volume_);
      if (s.killer >= 0) {
        const auto it = std::find_if(learned_.begin(), learned_.end(), [&](const Learned& l) { return l.id == s.killer; });
        if (it != learned_.end()) std::rotate(learned_.begin(), it, it + 1);
      }
      continue;
    }
    if (!s.children.empty()) {
      done_volume_ += s.condemned;
      for (Box& c : s.children) open_.push(std::move(c));
      blocked = true;
      continue;
    }
    b.settled = s.settled;
    if (blocked) {
      open_.push(b);
      continue;
    }
    blocked = true;
    if (certify(b, res, s.planned_s)) return true;
  }
  return false;
}

void OptimalSearch::time_lowest_first(PlacementResult& res) {
  // Without a first time, every box whose bound lies below the first point's time is split
  // before any point is timed; where the bound is loose (a hexapod's sliders, a path the feeds
  // set) that is the whole grid.
  OptimalSearch lowest(scene_, checker_, PlacementOptions::Objective::lowest, rot_, threads_, 0.0, term_, nullptr);
  lowest.bare_ = true;
  const PlacementResult first = lowest.run();
  res.certifications += first.certifications;
  res.placements_examined += first.placements_examined;
  learned_ = lowest.learned_;
  if (!first.summary.done()) return;
  for (std::size_t r = 0; r < rot_.shown.size(); ++r)
    if (rot_.shown[r] == first.placement.rotation_deg) {
      best_time_s_ = planned_at_[r]->planned_s(first.placement.offset());
      best_timed_ = first.placement;
      ++timed_;
    }
}

PlacementResult OptimalSearch::run() {
  PlacementResult res;
  if (!prepare(res)) return res;
  if (timed()) time_lowest_first(res);
  std::vector<Box> batch;
  std::vector<Screened> screened;
  bool found = false;
  while (!open_.empty() && !found && change_refusals_ < kMaxChangeRefusals && !time_settled()) {
    if (term_.should_end()) throw WorkEnded{term_.reason()};
    batch.clear();
    while (!open_.empty() && batch.size() < batch_) {
      batch.push_back(open_.top());
      open_.pop();
    }
    res.placements_examined += static_cast<long>(batch.size());
    screened.assign(batch.size(), Screened{});
    const std::vector<Learned> known = learned_;
    tbb::parallel_for(std::size_t{0}, batch.size(), [&](std::size_t k) { screened[k] = screen(batch[k], known); });
    found = merge(batch, screened, res);
  }
  const int nrot = static_cast<int>(rot_.deg.size());
  if (timed() && best_timed_set()) {
    found = true;
    res.summary.status = Status::done;
    res.placement = best_timed_;
    res.objective_value = best_time_s_;
    res.time_lower_bound_s = std::min(best_time_s_, time_left_bound_s_);
    if (!open_.empty()) res.time_lower_bound_s = std::min(res.time_lower_bound_s, open_.top().key.primary);
  }
  if (!found && change_refusals_ >= kMaxChangeRefusals) {
    res.summary.status = Status::budget;
    res.summary.message = fmt::format("gave up after {} candidate placements refused on the tool changes' moves (the "
                                      "last: {}); the machine's tool_change position may be out of reach of this job",
                                      change_refusals_, last_.what);
    res.report = checker_.report(at(0, 0, 0, rot_.best(0, nrot - 1)), term_);
    return res;
  }
  if (!found) {
    res.summary.status = Status::infeasible;
    res.summary.message = fmt::format("no placement on the table with a pad up to {:.0f} mm is free of interference{}",
                                      scene_.search.pad_max_mm, last_.what.empty() ? "" : fmt::format(" (e.g. {})", last_.what));
    res.report = checker_.report(at(0, 0, 0, rot_.best(0, nrot - 1)), term_);
    return res;
  }
  res.summary.message = lexicographic()
                            ? fmt::format("lowest pad, then nearest the centre{}, on a {:.3g} mm grid",
                                          nrot > 1 ? ", then the smallest rotation" : "", g_)
                            : timed() ? time_message(res)
                                      : fmt::format("least {} on a {:.3g} mm grid", to_string(objective_), g_);
  if (bare_) return res;
  res.report = checker_.report(res.placement, term_);
  if (nrot > 1) certify_rotation_interval(res);
  return res;
}

std::string OptimalSearch::time_message(const PlacementResult& res) const {
  const std::string timed = fmt::format("{} placement{} timed by the feed planner", timed_, timed_ == 1 ? "" : "s");
  if (res.time_lower_bound_s >= best_time_s_)
    return fmt::format("least planned machining time on a {:.3g} mm grid ({})", g_, timed);
  return fmt::format("least planned machining time of {} (the lowest placement first, then by their bounds); no "
                     "placement on the {:.3g} mm grid takes less than {:.1f} s ({:.1f} % below)",
                     timed, g_, res.time_lower_bound_s, 100.0 * (1.0 - res.time_lower_bound_s / best_time_s_));
}

void OptimalSearch::certify_rotation_interval(PlacementResult& res) {
  // The widest turn around the answer, up to half the rotation grid's step, over which the
  // answer is certified free; none with tool changes, whose moves are certified at single
  // placements (Checker::decide).
  if (scene_.tool_change && scene_.runs.size() > 1) return;
  double step = 360.0;
  for (std::size_t k = 1; k < rot_.deg.size(); ++k) step = std::min(step, rot_.deg[k] - rot_.deg[k - 1]);
  for (double turn = std::min(step, 1.0) / 2; turn >= 0.004; turn /= 2)
    if (checker_.decide(res.placement, {0.0, turn}, term_) == Decision::feasible) {
      res.rotation_tolerance_deg = turn;
      return;
    }
}

}  // namespace

Eigen::AlignedBox2d placement_region(const Scene& scene, double rotation_deg) {
  const Eigen::Rotation2Dd R(rotation_deg * kDeg);
  Eigen::AlignedBox2d fp;
  const auto& b = scene.workpiece_bounds;
  for (int k = 0; k < 4; ++k)
    fp.extend(R * Eigen::Vector2d(k & 1 ? b.max().x() : b.min().x(), k & 2 ? b.max().y() : b.min().y()));
  const Eigen::Vector2d half = scene.model->table().half_mm;
  return Eigen::AlignedBox2d(-half - fp.min(), half - fp.max());
}


namespace {
Rotations rotations_for(const Scene& scene, const PlacementOptions& o, bool* reduced) {
  Rotations rot;
  *reduced = false;
  std::vector<double> asked = o.rotations_deg;
  if (o.any_rotation) {
    asked.clear();
    const double step = scene.search.rotation_step_deg;
    const long lo = static_cast<long>(std::floor(-180.0 / step)) + 1, hi = static_cast<long>(std::floor(180.0 / step + 1e-9));
    for (long k = lo; k <= hi; ++k) asked.push_back(normalized_deg(k * step));
  }
  // A machine whose rotary table turns nothing but the workpiece: a rotation is the same
  // setup as a position, so one rotation is searched.
  if (asked.size() > 1 && scene.model->rotation_is_position() && scene.peripherals.empty()) {
    *reduced = true;
    double nearest = asked[0];
    for (double a : asked)
      if (std::abs(normalized_deg(a)) < std::abs(normalized_deg(nearest))) nearest = a;
    asked = {nearest};
  }
  std::vector<std::pair<double, double>> both;
  for (double a : asked) both.push_back({normalized_deg(a), a});
  std::sort(both.begin(), both.end());
  for (const auto& [n, a] : both) rot.deg.push_back(n), rot.shown.push_back(a);
  return rot;
}
}  // namespace

PlacementResult place(const Scene& scene, const PlacementOptions& o, Termination& term, Progress* progress) {
  o.validate();
  PlacementOptions::Objective objective = o.objective;
  if (objective == PlacementOptions::Objective::automatic)
    objective = scene.model->affine_axes() ? PlacementOptions::Objective::travel : PlacementOptions::Objective::lowest;
  if (objective == PlacementOptions::Objective::travel && !scene.model->affine_axes())
    throw InputError::field("objective", fmt::format("'travel' needs a machine whose axis positions are affine in the "
                                                     "placement (a table-tilting machine); the {} machine '{}' is placed "
                                                     "by 'lowest' or 'time'",
                                                     scene.machine.kind, scene.machine.name));
  if (objective == PlacementOptions::Objective::time && !scene.model->has_axis_path())
    throw InputError::field("objective", fmt::format("'time' needs a machine whose axes the feed planner can time; the {} "
                                                     "machine '{}' is placed by 'lowest'",
                                                     scene.machine.kind, scene.machine.name));
  if (o.strategy == PlacementOptions::Strategy::paper && scene.machine.kind != "hexapod")
    throw InputError::field("strategy", "'paper' is the HexaM study's evasion search, defined for the hexapod only");
  const int threads = o.threads > 0 ? o.threads : tbb::this_task_arena::max_concurrency();
  tbb::task_arena arena(threads);
  const double t0 = now_s();
  PlacementResult best;
  bool reduced = false;
  arena.execute([&] {
    try {
      Checker checker(scene);
      if (o.strategy == PlacementOptions::Strategy::paper) {
        best = paper_search(scene, checker, term);
      } else {
        OptimalSearch search(scene, checker, objective, rotations_for(scene, o, &reduced), threads, o.time_gap_pct, term,
                             progress);
        best = search.run();
      }
      best.counts = checker.counts();
    } catch (const WorkEnded& e) {
      // A stop request, a deadline or a budget inside one decision: no partial answer.
      best = PlacementResult{};
      best.summary.status = status_of(e.reason);
      best.summary.message = e.reason == Termination::Reason::budget && !term.ended() ? budget_message(scene) : term.describe();
    }
  });
  best.objective = objective;
  best.threads = threads;
  best.verified = best.summary.done() && best.report.free();
  if (best.summary.done()) {
    best.work_offset = scene.model->work_offset(best.placement, -scene.origin_in_cam_mm);
    // On a hexapod the sliders' travel and time cost the inverse kinematics of every pose:
    // reported when the time was the objective.
    if (scene.model->affine_axes() || objective == PlacementOptions::Objective::time) {
      const Eigen::Vector3d centre(0, 0, scene.pad_min_mm());
      std::vector<AxisTravel> t = axis_travel(scene, best.placement.rotation_deg, {best.placement.offset(), centre});
      if (!t.empty()) best.travel = t[0], best.centre_travel = t[1];
    }
  }
  best.seconds = now_s() - t0;
  write_place_summary(scene, o, reduced, best);
  return best;
}

const char* to_string(PlacementOptions::Objective o) {
  switch (o) {
    case PlacementOptions::Objective::automatic: return "automatic";
    case PlacementOptions::Objective::lowest: return "lowest";
    case PlacementOptions::Objective::travel: return "travel";
    case PlacementOptions::Objective::time: return "time";
  }
  return "?";
}

PlacementOptions::Objective parse_objective(std::string_view text) {
  for (auto o : {PlacementOptions::Objective::automatic, PlacementOptions::Objective::lowest,
                 PlacementOptions::Objective::travel, PlacementOptions::Objective::time})
    if (text == to_string(o)) return o;
  throw InputError::field("objective", fmt::format("'{}': must be lowest, travel, time or automatic", text.substr(0, 40)));
}

void parse_rotations(std::string_view text, PlacementOptions& o) {
  auto fail = [](const std::string& msg) { throw InputError::field("rotations_deg", msg); };
  auto number = [&](std::string_view item) {
    const std::optional<double> v = parse_finite(std::string(item));
    if (!v) fail(fmt::format("'{}' is not a number", item.substr(0, 40)));
    return *v;
  };
  o.rotations_deg.clear();
  o.any_rotation = false;
  if (text == "any") {
    o.any_rotation = true;
    return;
  }
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string_view item = text.substr(start, comma - start);
    start = comma + 1;
    const std::size_t c1 = item.find(':');
    if (c1 == std::string_view::npos) {
      o.rotations_deg.push_back(number(item));
    } else {
      // FROM:TO:STEP, TO excluded when it is the same angle as FROM.
      const std::size_t c2 = item.find(':', c1 + 1);
      if (c2 == std::string_view::npos) fail(fmt::format("range '{}': expected FROM:TO:STEP", item.substr(0, 40)));
      const double from = number(item.substr(0, c1)), to = number(item.substr(c1 + 1, c2 - c1 - 1)),
                   step = number(item.substr(c2 + 1));
      if (!(step > 0) || to < from) fail(fmt::format("range '{}': needs FROM <= TO and a positive STEP", item.substr(0, 40)));
      const double count = std::floor((to - from) / step + 1e-9) + 1;
      if (count > static_cast<double>(PlacementOptions::kMaxRotations))
        fail(fmt::format("range '{}' has {:.0f} rotations; at most {}", item.substr(0, 40), count, PlacementOptions::kMaxRotations));
      for (long k = 0; k < static_cast<long>(count); ++k) {
        const double a = from + k * step;
        if (k > 0 && std::abs(std::remainder(a - from, 360.0)) < 1e-9) break;
        o.rotations_deg.push_back(a);
      }
    }
    if (comma == text.size()) break;
  }
}

void PlacementOptions::validate() const {
  if (threads < 0 || threads > 1024) throw InputError::field("threads", fmt::format("{}: must lie within 0 .. 1024", threads));
  if (!(time_gap_pct >= 0.0 && time_gap_pct <= 50.0))
    throw InputError::field("time_gap_pct", fmt::format("{}: must lie within 0 .. 50 (per cent)", time_gap_pct));
  if (strategy == Strategy::paper && (any_rotation || rotations_deg != std::vector<double>{0.0}))
    throw InputError::field("rotations_deg", "the paper strategy searches the workpiece as given (rotation 0); "
                                             "other rotations need the optimal strategy");
  if (any_rotation) return;
  if (rotations_deg.empty()) throw InputError::field("rotations_deg", "needs at least one rotation");
  if (rotations_deg.size() > kMaxRotations)
    throw InputError::field("rotations_deg",
                            fmt::format("{} rotations; at most {} are searched", rotations_deg.size(), kMaxRotations));
  std::vector<std::pair<double, std::size_t>> sorted;
  for (std::size_t i = 0; i < rotations_deg.size(); ++i) {
    const double r = rotations_deg[i];
    if (!std::isfinite(r) || std::abs(r) > 360.0)
      throw InputError::field("rotations_deg", fmt::format("rotation {} deg: must be a finite angle within -360 .. 360", r));
    sorted.push_back({normalized_deg(r), i});
  }
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t k = 1; k < sorted.size(); ++k)
    if (std::abs(sorted[k].first - sorted[k - 1].first) < 1e-9 ||
        (k == sorted.size() - 1 && std::abs(sorted[k].first - sorted[0].first - 360) < 1e-9)) {
      const std::size_t a = std::min(sorted[k].second, sorted[k - 1].second), b = std::max(sorted[k].second, sorted[k - 1].second);
      throw InputError::field("rotations_deg", fmt::format("rotation {} deg repeats {} deg; each angle is searched once",
                                                           rotations_deg[b], rotations_deg[a]));
    }
}

namespace {
constexpr Spelling kStrategyNames[] = {{"paper"}, {"optimal"}};
}  // namespace

const char* to_string(PlacementOptions::Strategy s) { return kStrategyNames[static_cast<std::size_t>(s)].name.data(); }

Parsed<PlacementOptions::Strategy> parse_placement_strategy(std::string_view text) {
  const Parsed<std::size_t> p = parse_name(kStrategyNames, text, "strategy", "strategy");
  return {static_cast<PlacementOptions::Strategy>(p.value), p.note};
}

}  // namespace machplan::placement
