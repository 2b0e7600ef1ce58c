#include "solvers/nesting/strip_search.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <random>
#include <utility>

#include <boost/geometry/index/rtree.hpp>
#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include "solvers/nesting/internal/shape.h"

namespace machplan::nesting {

namespace {

namespace bgi = boost::geometry::index;
using Tree = bgi::rtree<std::pair<Box, std::size_t>, bgi::quadratic<16>>;

// The search's settings (after sparrow's, checked on the ESICUP strip-packing instances).
constexpr int kContainerSamples = 50;   // places anywhere in the strip, per move
constexpr int kFocusSamples = 25;       // places over the part's own box, per move
constexpr int kDescents = 3;            // of the best distinct samples, refined by coordinate descent
constexpr double kDistinct = 0.05;      // of the part's smaller side: samples closer are one
// A descent's steps: along x and y, of the part's smaller side, first and last; of a part that
// turns freely, in degrees, first and last.
struct Steps {
  double first, last, first_deg, last_deg;
};
constexpr Steps kFirstSteps{0.25, 0.02, 5.0, 1.0};    // the best few samples'
constexpr Steps kFinalSteps{0.01, 0.001, 0.5, 0.05};  // the best one's final refinement
constexpr double kFreeTurnShare = 0.5;  // of the samples of a part that turns freely: at a random angle
// How long separation tries: rounds without 2 % less overlap before a strike, and strikes in a
// row before it gives up; exploring, then compressing (shorter tries, more of them), as sparrow.
struct Patience {
  int stale, strikes;
};
constexpr Patience kExplorePatience{200, 3};
constexpr Patience kCompressPatience{100, 5};
constexpr double kExploreShrink = 0.001;                  // exploring: the cut of the length after each success
constexpr double kCompressShrink[2] = {0.0005, 0.00001};  // compressing: the cut, falling with the time spent
constexpr double kExploreShare = 0.8;   // of the work: exploring, then compressing the best
constexpr double kEpsRatio = 0.01;      // of the larger diameter: where the poles' overlap starts to fade
constexpr double kWeightLeast = 1.2, kWeightMost = 2.0, kWeightDecay = 0.95;  // guided local search
constexpr double kLargeShare = 0.75;    // disruption swaps parts among the largest holding this share of hull area
constexpr std::size_t kPool = 64;       // exploring: the failed nests kept to go on from (the least overlap)

// A part's shape in the strip: one of the part's shapes (made once), or one turned freely to an
// angle of its own.
struct Turn {
  int shape = 0;                      // index into the part's shapes, when `own` is null
  std::shared_ptr<const Shape> own;   // turned by the search (a part that turns freely)
  bool same(const Turn& o) const {
    return own || o.own ? own && o.own && own->mirrored == o.own->mirrored && std::abs(own->rotation_deg - o.own->rotation_deg) < 1.0
                        : shape == o.shape;
  }
};

const Shape& shape_of(const ShapeSet& shapes, std::size_t part, const Turn& t) {
  return t.own ? *t.own : shapes[part][static_cast<std::size_t>(t.shape)];
}

struct Item {
  std::size_t placement = 0;  // index into the nest's placements
  std::size_t part = 0;
  Turn turn;
  Eigen::Vector2d at = Eigen::Vector2d::Zero();
};

struct Candidate {
  Turn turn;
  Eigen::Vector2d at;
  double value = std::numeric_limits<double>::infinity();
};

struct Collision {
  std::size_t i = 0, j = 0;
  double value = 0.0;
};

// The best few distinct candidates seen.
struct BestFew {
  std::vector<Candidate> kept;
  double distinct = 0.0;
  double bound() const { return kept.size() < kDescents ? std::numeric_limits<double>::infinity() : kept.back().value; }
  void offer(const Candidate& c) {
    for (Candidate& k : kept)
      if (k.turn.same(c.turn) && (k.at - c.at).norm() < distinct) {
        if (c.value < k.value) k = c;
        std::sort(kept.begin(), kept.end(), [](const Candidate& a, const Candidate& b) { return a.value < b.value; });
        return;
      }
    if (c.value >= bound()) return;
    kept.push_back(c);
    std::sort(kept.begin(), kept.end(), [](const Candidate& a, const Candidate& b) { return a.value < b.value; });
    if (kept.size() > kDescents) kept.pop_back();
  }
};

// The search's strip (or a mover's copy of it): the last sheet's parts in a usable area whose end moves.
class Strip {
 public:
  Strip(const ShapeSet& shapes, std::vector<bool> free, std::vector<Item> items, const Eigen::AlignedBox2d& usable, double end_x,
        std::uint64_t seed, Termination& t)
      : shapes_(shapes), free_(std::move(free)), usable_(usable), end_(end_x), rng_(seed), t_(t),
        weights_(std::make_shared<std::vector<float>>(items.size() * items.size(), 1.0f)) {
    load(std::move(items));
  }

  // Shrinks the strip until the work ends; the shortest feasible nest found, its end in `best_end`.
  // Each one found is offered to `progress` (when not null), with the share of the work spent.
  std::vector<Item> search(double& best_end, StripSearchStats& stats, NestProgress* progress);

  // `n` movers (none below 2: the search then moves the parts itself), seeded from this strip's seed.
  void add_movers(int n) {
    for (int w = 0; w < n && n > 1; ++w) {
      auto m = std::make_unique<Strip>(shapes_, free_, items_, usable_, end_, rng_(), t_);
      m->weights_ = weights_;
      m->mover_ = true;
      movers_.push_back(std::move(m));
    }
  }

 private:
  const Shape& shape_of(std::size_t part, int s) const { return shapes_[part][static_cast<std::size_t>(s)]; }
  const Shape& shape_of(std::size_t part, const Turn& t) const { return nesting::shape_of(shapes_, part, t); }
  const Shape& shape(std::size_t i) const { return shape_of(items_[i].part, items_[i].turn); }
  float& weight(std::size_t i, std::size_t j) { return (*weights_)[i * items_.size() + j]; }
  double right(std::size_t i) const { return items_[i].at.x() + shape(i).part_box.max().x(); }
  double end_of_parts() const;

  // The places a shape's reference point may take in the strip (empty when it is too long).
  Eigen::AlignedBox2d range(const Shape& s) const {
    return Eigen::AlignedBox2d(usable_.min() - s.part_box.min(),
                               Eigen::Vector2d(end_ - s.part_box.max().x(), usable_.max().y() - s.part_box.max().y()));
  }

  void load(std::vector<Item> items);
  void put(std::size_t i, const Turn& turn, const Eigen::Vector2d& at);
  Turn turned(const Shape& base, double deg);
  double overlap(const Shape& a, const Eigen::Vector2d& at, std::size_t j);
  double evaluate(std::size_t i, const Shape& a, const Eigen::Vector2d& at, double bound);
  Candidate candidate(std::size_t i, Turn turn, Eigen::Vector2d at, double bound);
  Candidate descend(std::size_t i, Candidate c, const Steps& steps);
  void move(std::size_t i);
  std::vector<Collision> collisions();
  void reweigh(const std::vector<Collision>& c);
  double separate(const Patience& patience);
  bool resize(double end_x, double split_x);
  void disrupt();
  void charge();
  std::vector<const Strip*> all() const {  // this strip and its movers
    std::vector<const Strip*> out{this};
    for (const auto& m : movers_) out.push_back(m.get());
    return out;
  }
  std::vector<Collision> move_all(const std::vector<Collision>& c);

  const ShapeSet& shapes_;
  std::vector<bool> free_;  // per part: whether it turns freely
  Eigen::AlignedBox2d usable_;
  double end_;
  std::mt19937_64 rng_;
  Termination& t_;
  std::shared_ptr<std::vector<float>> weights_;  // per pair of parts; the movers share the search's
  // Movers: copies of the strip that each move the colliding parts from where the search has
  // them, in an order of their own, on threads of their own; the search goes on from the one
  // that leaves the least weighted overlap (as sparrow's separator does). None: the search moves
  // them itself.
  std::vector<std::unique_ptr<Strip>> movers_;
  bool mover_ = false;     // whether this is a mover: its work is kept in `pending_s_`, charged by the search
  double pending_s_ = 0.0;
  std::vector<Item> items_;
  std::vector<Box> boxes_;
  Tree tree_;
  std::int64_t tests_ = 0, pole_pairs_ = 0, deep_pairs_ = 0, moves_ = 0, all_tests_ = 0, all_pole_pairs_ = 0, all_deep_pairs_ = 0;
  std::int64_t steps_at_ = meets_steps(), all_steps_ = 0;  // meets()'s steps on this thread: when last charged, charged
};

void Strip::load(std::vector<Item> items) {
  items_ = std::move(items);
  boxes_.clear();
  tree_.clear();
  for (std::size_t i = 0; i < items_.size(); ++i) {
    const Shape& s = shape(i);
    boxes_.push_back(moved(s.box, items_[i].at.x(), items_[i].at.y()));
    tree_.insert({boxes_[i], i});
  }
}

void Strip::put(std::size_t i, const Turn& turn, const Eigen::Vector2d& at) {
  tree_.remove(std::make_pair(boxes_[i], i));
  items_[i].turn = turn;
  items_[i].at = at;
  boxes_[i] = moved(shape(i).box, at.x(), at.y());
  tree_.insert({boxes_[i], i});
}

double Strip::end_of_parts() const {
  double e = usable_.min().x();
  for (std::size_t i = 0; i < items_.size(); ++i) e = std::max(e, right(i));
  return e;
}

// How much `a` at `at` overlaps part j: 0 when they do not collide, else the depth of their
// poles in each other, each pair of poles weighed by the smaller radius; a pair apart adds a
// little that fades with its distance, so the measure stays above 0 and still falls as the parts
// part. Its root, scaled by the parts' sizes (larger parts weigh more).
double Strip::overlap(const Shape& a, const Eigen::Vector2d& at, std::size_t j) {
  const Shape& b = shape(j);
  const Eigen::Vector2d d = at - items_[j].at;
  const float dx = static_cast<float>(d.x()), dy = static_cast<float>(d.y());
  const std::size_t nb = b.poles.padded();
  // b's poles kLanes at a time, as Eigen packets (vectorised).
  using Lane = Eigen::Array<float, Poles::kLanes, 1>;
  const auto lanes = [](const std::vector<float>& v, std::size_t q0) { return Eigen::Map<const Lane>(v.data() + q0); };
  // Whether they collide: two poles that overlap say so at once, else the polygons decide.
  bool deep = false;
  for (std::size_t k = 0; k < a.poles.size() && !deep; ++k) {
    const float cx = a.poles.x[k] + dx, cy = a.poles.y[k] + dy, ra = a.poles.radius[k];
    for (std::size_t q0 = 0; q0 < nb && !deep; q0 += Poles::kLanes)
      deep = ((lanes(b.poles.x, q0) - cx).square() + (lanes(b.poles.y, q0) - cy).square() < (lanes(b.poles.radius, q0) + ra).square()).any();
    deep_pairs_ += static_cast<std::int64_t>(nb);
  }
  if (!deep) {
    ++tests_;
    if (!meets(a, at, b, items_[j].at)) return 0.0;
  }
  const float eps = static_cast<float>(kEpsRatio * std::max(a.diameter_mm, b.diameter_mm));
  Lane lane = Lane::Zero();
  for (std::size_t k = 0; k < a.poles.size(); ++k) {
    const float cx = a.poles.x[k] + dx, cy = a.poles.y[k] + dy, ra = a.poles.radius[k];
    for (std::size_t q0 = 0; q0 < nb; q0 += Poles::kLanes) {
      const Lane rb = lanes(b.poles.radius, q0);
      const Lane pd = (rb + ra) - ((lanes(b.poles.x, q0) - cx).square() + (lanes(b.poles.y, q0) - cy).square()).sqrt();
      const Lane fade = (eps * eps) / (2 * eps - pd).max(eps);
      lane += (pd >= eps).select(pd, fade) * rb.min(ra);
    }
  }
  const double sum = lane.sum();
  pole_pairs_ += static_cast<std::int64_t>(a.poles.size() * nb);
  return std::sqrt(sum + static_cast<double>(eps) * eps) * std::sqrt(std::sqrt(a.hull_area_mm2 * b.hull_area_mm2));
}

// `base` turned to `deg`, its vertices counted as steps of work.
Turn Strip::turned(const Shape& base, double deg) {
  meets_steps() += base.vertices;
  return {0, std::make_shared<const Shape>(turned_shape(base, deg))};
}

// The weighted overlap of part i as `a` at `at` with the others; stops once past `bound`.
double Strip::evaluate(std::size_t i, const Shape& a, const Eigen::Vector2d& at, double bound) {
  double sum = 0.0;
  for (auto it = tree_.qbegin(bgi::intersects(moved(a.box, at.x(), at.y()))); it != tree_.qend() && sum <= bound; ++it)
    if (it->second != i) sum += weight(i, it->second) * overlap(a, at, it->second);
  return sum;
}

// Part i turned so at `at` kept in the strip, evaluated (infinite when it does not fit).
Candidate Strip::candidate(std::size_t i, Turn turn, Eigen::Vector2d at, double bound) {
  const Shape& a = shape_of(items_[i].part, turn);
  const Eigen::AlignedBox2d r = range(a);
  if (r.isEmpty()) return {std::move(turn), at};
  at = at.cwiseMax(r.min()).cwiseMin(r.max());
  const double value = evaluate(i, a, at, bound);
  return {std::move(turn), at, value};
}

// Coordinate descent: a step both ways along an axis (x, y, a diagonal, or for a part that
// turns freely its angle, about its box's centre); on success the step grows a little and the
// axis stays, else it halves and another axis is drawn.
Candidate Strip::descend(std::size_t i, Candidate c, const Steps& steps) {
  const std::size_t part = items_[i].part;
  const Eigen::Vector2d size = shape_of(part, c.turn).part_box.sizes();
  const double side = std::min(size.x(), size.y()), last = steps.last * side;
  Eigen::Vector2d step = Eigen::Vector2d::Constant(steps.first * side);
  double turn_step = free_[part] ? steps.first_deg : 0.0;
  static const Eigen::Vector2d kAxes[4] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
  std::uniform_int_distribution<int> axis_of(0, free_[part] ? 4 : 3);
  int axis = axis_of(rng_);
  while ((step.x() >= last || step.y() >= last || turn_step >= steps.last_deg) && c.value > 0) {
    Candidate best = c;
    if (axis == 4) {
      const Shape& now = shape_of(part, c.turn);
      for (const double sign : {1.0, -1.0}) {
        Turn t = turned(now, now.rotation_deg + sign * turn_step);
        const Eigen::Vector2d at = c.at + now.part_box.center() - t.own->part_box.center();
        Candidate n = candidate(i, std::move(t), at, best.value);
        if (n.value < best.value) best = std::move(n);
      }
      turn_step *= best.value < c.value ? 1.1 : 0.5;
    } else {
      const Eigen::Vector2d d = kAxes[axis].cwiseProduct(step);
      for (const Eigen::Vector2d& at : {Eigen::Vector2d(c.at + d), Eigen::Vector2d(c.at - d)}) {
        Candidate n = candidate(i, c.turn, at, best.value);
        if (n.value < best.value) best = std::move(n);
      }
      const Eigen::Vector2d on(axis == 1 ? 0.0 : 1.0, axis == 0 ? 0.0 : 1.0);  // the coordinates the axis moves
      const Eigen::Vector2d keep = Eigen::Vector2d::Ones() - on;
      step = step.cwiseProduct(keep + (best.value < c.value ? 1.1 : 0.5) * on);
    }
    if (best.value < c.value) c = std::move(best);
    else axis = axis_of(rng_);
  }
  return c;
}

// Moves part i to the best place found: its own, samples over its box and over the strip, the
// best few refined by coordinate descent and the best of those refined again.
void Strip::move(std::size_t i) {
  const Item now = items_[i];
  const Eigen::Vector2d size = shape(i).part_box.sizes();
  BestFew best;
  best.distinct = kDistinct * std::min(size.x(), size.y());
  if (!range(shape(i)).isEmpty()) best.offer(candidate(i, now.turn, now.at, best.bound()));
  std::uniform_int_distribution<int> any_shape(0, static_cast<int>(shapes_[now.part].size()) - 1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const Eigen::Vector2d centre = now.at + shape(i).part_box.center();
  for (int k = 0; k < kFocusSamples + kContainerSamples; ++k) {
    Turn turn{any_shape(rng_), nullptr};
    if (free_[now.part] && unit(rng_) < kFreeTurnShare) turn = turned(shape_of(now.part, turn.shape), 360.0 * unit(rng_));
    const Shape& sh = shape_of(now.part, turn);
    const Eigen::AlignedBox2d r = range(sh);
    if (r.isEmpty()) continue;
    const Eigen::Vector2d u(unit(rng_), unit(rng_));
    const Eigen::Vector2d at = k < kFocusSamples ? Eigen::Vector2d(centre - sh.part_box.center() + (u - Eigen::Vector2d::Constant(0.5)).cwiseProduct(size))
                                                 : Eigen::Vector2d(r.min() + r.sizes().cwiseProduct(u));
    best.offer(candidate(i, std::move(turn), at, best.bound()));
  }
  if (best.kept.empty()) return;  // no shape of it fits the strip: resize keeps that from happening
  for (std::size_t k = 0, n = best.kept.size(); k < n; ++k) best.offer(descend(i, best.kept[k], kFirstSteps));
  const Candidate c = descend(i, best.kept.front(), kFinalSteps);
  if (c.turn.own != now.turn.own || c.turn.shape != now.turn.shape || c.at != now.at) put(i, c.turn, c.at);
  ++moves_;
  charge();
}

void Strip::charge() {
  const std::int64_t steps = meets_steps() - steps_at_;
  steps_at_ = meets_steps();
  const double work = static_cast<double>(tests_) * kSearchTestCostS + static_cast<double>(steps) * kMeetsStepCostS +
                      static_cast<double>(pole_pairs_) * kPoleCostS + static_cast<double>(deep_pairs_) * kDeepPairCostS;
  if (mover_) pending_s_ += work;
  else t_.charge(0, work);
  all_tests_ += tests_, all_pole_pairs_ += pole_pairs_, all_deep_pairs_ += deep_pairs_, all_steps_ += steps;
  tests_ = pole_pairs_ = deep_pairs_ = 0;
}

std::vector<Collision> Strip::collisions() {
  std::vector<Collision> out;
  for (std::size_t i = 0; i < items_.size(); ++i) {
    for (auto it = tree_.qbegin(bgi::intersects(boxes_[i])); it != tree_.qend(); ++it)
      if (it->second > i)
        if (const double v = overlap(shape(i), items_[i].at, it->second); v > 0) out.push_back({i, it->second, v});
  }
  charge();
  return out;
}

void Strip::reweigh(const std::vector<Collision>& c) {
  for (float& w : *weights_) w = std::max(1.0f, w * static_cast<float>(kWeightDecay));
  double most = 0.0;
  for (const Collision& k : c) most = std::max(most, k.value);
  for (const Collision& k : c) {
    const double grow = kWeightLeast + (kWeightMost - kWeightLeast) * k.value / most;
    // The decay above is undone for the colliding pairs: they grow from where they were.
    const float w = static_cast<float>(std::max(1.0, weight(k.i, k.j) / kWeightDecay * grow));
    weight(k.i, k.j) = weight(k.j, k.i) = w;
  }
}

// Moves each part of the collisions `c` that still collides when its turn comes, in a random
// order, by itself or by its movers (the best of theirs kept); the collisions after.
std::vector<Collision> Strip::move_all(const std::vector<Collision>& c) {
  std::vector<std::size_t> who;
  for (const Collision& k : c) who.push_back(k.i), who.push_back(k.j);
  std::sort(who.begin(), who.end());
  who.erase(std::unique(who.begin(), who.end()), who.end());
  const auto move_in = [&who](Strip& s) {
    std::vector<std::size_t> order = who;
    std::shuffle(order.begin(), order.end(), s.rng_);
    for (std::size_t i : order)
      if (s.evaluate(i, s.shape(i), s.items_[i].at, 0.0) > 0) s.move(i);
    return s.collisions();
  };
  if (movers_.empty()) return move_in(*this);
  std::vector<std::vector<Collision>> after(movers_.size());
  std::vector<double> loss(movers_.size(), 0.0);
  tbb::parallel_for(std::size_t{0}, movers_.size(), [&](std::size_t w) {
    Strip& m = *movers_[w];
    m.items_ = items_, m.boxes_ = boxes_, m.tree_ = tree_, m.end_ = end_;
    m.steps_at_ = meets_steps();  // this thread's
    after[w] = move_in(m);
    for (const Collision& k : after[w]) loss[w] += m.weight(k.i, k.j) * k.value;
  });
  // This thread may have run a mover: its steps are that mover's, charged by it.
  steps_at_ = meets_steps();
  const std::size_t w = static_cast<std::size_t>(std::min_element(loss.begin(), loss.end()) - loss.begin());
  std::swap(items_, movers_[w]->items_), std::swap(boxes_, movers_[w]->boxes_), std::swap(tree_, movers_[w]->tree_);
  double most = 0.0;  // the movers ran side by side: the work is the longest one's
  for (auto& m : movers_) most = std::max(most, std::exchange(m->pending_s_, 0.0));
  t_.charge(0, most);
  return after[w];
}

// Moves colliding parts until none collides, or separation stalls, or the work ends; leaves the
// parts at the least overlap found and returns it (0: separated).
double Strip::separate(const Patience& patience) {
  std::vector<Collision> c = collisions();
  const auto total_of = [](const std::vector<Collision>& cs) {
    double total = 0.0;
    for (const Collision& k : cs) total += k.value;
    return total;
  };
  std::vector<Item> best = items_;
  double least = total_of(c);
  for (int strike = 0; strike < patience.strikes && least > 0 && !t_.should_end();) {
    const double at_strike = least;
    for (int stale = 0; stale < patience.stale && !t_.should_end();) {
      c = move_all(c);
      const double total = total_of(c);
      if (total == 0) return 0.0;
      if (total < least) {
        if (total < 0.98 * least) stale = 0;
        else ++stale;
        least = total, best = items_;
      } else {
        ++stale;
      }
      reweigh(c);
    }
    strike = least < 0.98 * at_strike ? 0 : strike + 1;
    load(best);
    c = collisions();
  }
  return least;
}

// The strip ends at `end_x`: the parts whose centre lies right of `split_x` move by the change
// (and into the strip where that leaves them out of it). False when a part fits it in no rotation.
bool Strip::resize(double end_x, double split_x) {
  const double delta = end_x - end_;
  end_ = end_x;
  for (std::size_t i = 0; i < items_.size(); ++i) {
    const auto& shapes = shapes_[items_[i].part];
    if (std::none_of(shapes.begin(), shapes.end(), [&](const Shape& s) { return !range(s).isEmpty(); })) return false;
  }
  for (std::size_t i = 0; i < items_.size(); ++i) {
    Eigen::Vector2d at = items_[i].at;
    if (at.x() + shape(i).part_box.center().x() > split_x) at.x() += delta;
    Turn turn = items_[i].turn;
    if (range(shape(i)).isEmpty())  // too long in this rotation for the strip now: the first that fits
      for (turn = Turn{}; range(shape_of(items_[i].part, turn)).isEmpty(); ++turn.shape) {
      }
    const Eigen::AlignedBox2d r = range(shape_of(items_[i].part, turn));
    put(i, turn, at.cwiseMax(r.min()).cwiseMin(r.max()));
  }
  std::fill(weights_->begin(), weights_->end(), 1.0f);
  return true;
}

// Two large parts of different sizes trade places (their boxes' centres), to leave a stalled
// separation somewhere new.
void Strip::disrupt() {
  std::vector<double> hulls;
  for (std::size_t i = 0; i < items_.size(); ++i) hulls.push_back(shape(i).hull_area_mm2);
  std::vector<double> sorted = hulls;
  std::sort(sorted.rbegin(), sorted.rend());
  const double total = std::accumulate(sorted.begin(), sorted.end(), 0.0);
  double sum = 0.0, cutoff = sorted.back();
  for (double h : sorted)
    if ((sum += h) > kLargeShare * total) {
      cutoff = h;
      break;
    }
  std::vector<std::size_t> large;
  for (std::size_t i = 0; i < items_.size(); ++i)
    if (hulls[i] >= cutoff) large.push_back(i);
  if (large.size() < 2) return;
  const std::size_t a = large[std::uniform_int_distribution<std::size_t>(0, large.size() - 1)(rng_)];
  std::vector<std::size_t> others;
  for (std::size_t i : large)
    if (std::abs(hulls[i] - hulls[a]) > 0.01 * hulls[a]) others.push_back(i);
  if (others.empty())
    for (std::size_t i : large)
      if (i != a) others.push_back(i);
  const std::size_t b = others[std::uniform_int_distribution<std::size_t>(0, others.size() - 1)(rng_)];
  const Eigen::Vector2d ca = items_[a].at + shape(a).part_box.center(), cb = items_[b].at + shape(b).part_box.center();
  for (const auto& [i, to] : {std::pair{a, cb}, std::pair{b, ca}}) {
    const Eigen::AlignedBox2d r = range(shape(i));
    put(i, items_[i].turn, (to - shape(i).part_box.center()).cwiseMax(r.min()).cwiseMin(r.max()));
  }
}

// Exploring: shrink by kExploreShrink after every success; after a failure go on from one of the
// nests that failed at this length (the less overlap, the likelier), disrupted. Then compressing
// the best: shrink by a ratio that falls with the work spent, from the split at a random x;
// after a failure go back to the best.
std::vector<Item> Strip::search(double& best_end, StripSearchStats& stats, NestProgress* progress) {
  std::vector<Item> best = items_;
  const double start = usable_.min().x(), work = t_.deadline_s();
  const auto length = [&] { return best_end - start; };
  const auto report = [&] {
    if (!progress) return;
    progress->offer_length(best_end);
    progress->share.report(t_.work_s_spent() / work);
  };
  std::vector<std::pair<double, std::vector<Item>>> failed;
  std::normal_distribution<double> pick(0.0, 0.25);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  bool resized = resize(start + length() * (1 - kExploreShrink), start + length() / 2);
  while (!t_.should_end() && t_.work_s_spent() < kExploreShare * work) {
    report();
    if (!resized) break;
    ++stats.shrinks_tried;
    const double loss = separate(kExplorePatience);
    if (loss == 0) {
      best = items_, best_end = end_of_parts(), ++stats.shrinks_kept;
      failed.clear();
      resized = resize(start + length() * (1 - kExploreShrink), start + length() / 2);
      continue;
    }
    if (t_.should_end()) break;
    failed.emplace_back(loss, items_);
    std::sort(failed.begin(), failed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    if (failed.size() > kPool) failed.pop_back();
    const auto k = static_cast<std::size_t>(std::min(0.999, std::abs(pick(rng_))) * static_cast<double>(failed.size()));
    load(failed[k].second);
    disrupt();
  }
  while (!t_.should_end()) {
    report();
    const double spent = std::clamp((t_.work_s_spent() / work - kExploreShare) / (1 - kExploreShare), 0.0, 1.0);
    const double ratio = kCompressShrink[0] + (kCompressShrink[1] - kCompressShrink[0]) * spent;
    end_ = best_end;
    load(best);
    if (!resize(start + length() * (1 - ratio), start + unit(rng_) * length())) break;
    ++stats.shrinks_tried;
    if (separate(kCompressPatience) == 0) best = items_, best_end = end_of_parts(), ++stats.shrinks_kept;
  }
  report();
  for (const Strip* s : all()) {
    stats.moves += s->moves_;
    stats.tests += s->all_tests_;
    stats.meets_steps += s->all_steps_;
    stats.pole_pairs += s->all_pole_pairs_;
    stats.deep_pairs += s->all_deep_pairs_;
  }
  return best;
}

}  // namespace

void NestProgress::offer_length(double mm) noexcept {
  double now = last_length_mm.load(std::memory_order_relaxed);
  while ((now <= 0 || mm < now) && !last_length_mm.compare_exchange_weak(now, mm, std::memory_order_relaxed)) {
  }
}

StripSearchStats shorten_last_sheet(const NestRequest& r, const ShapeSet& shapes, NestResult& nest, Termination& t,
                                    std::uint64_t seed, int workers, NestProgress* progress) {
  StripSearchStats stats;
  int last = -1;
  for (std::size_t k = 0; k < nest.used_length_mm.size(); ++k)
    if (nest.used_length_mm[k] > 0) last = static_cast<int>(k);
  if (last < 0) return stats;
  const Sheet& sheet = r.sheets[static_cast<std::size_t>(last)];
  if (sheet.remnant) {
    stats.note = "the last sheet used is a remnant: the strip search shortens whole sheets only";
    return stats;
  }
  const Eigen::AlignedBox2d usable(Eigen::Vector2d::Constant(sheet.margin_mm),
                                   Eigen::Vector2d(sheet.width_mm - sheet.margin_mm, sheet.height_mm - sheet.margin_mm));
  std::vector<bool> free;
  for (std::size_t p = 0; p < r.parts.size(); ++p) free.push_back(r.turns_freely(p));
  std::vector<Item> items;
  for (std::size_t k = 0; k < nest.placements.size(); ++k) {
    const Placement& p = nest.placements[k];
    if (p.sheet != last) continue;
    const auto& ss = shapes[p.part];
    const auto s = std::find_if(ss.begin(), ss.end(), [&](const Shape& x) { return x.rotation_deg == p.rotation_deg && x.mirrored == p.mirrored; });
    items.push_back({k, p.part, Turn{static_cast<int>(s - ss.begin()), nullptr}, p.translate_mm});
  }
  if (items.size() < 2) return stats;
  if (items.size() > kMostParts) {
    stats.note = fmt::format("the last sheet holds {} parts; the strip search takes at most {}", items.size(), kMostParts);
    return stats;
  }
  stats.start_length_mm = nest.used_length_mm[static_cast<std::size_t>(last)];
  // A deadline of its own (the fills' work is not the search's), and the caller's stop request.
  const double work = t.deadline_s() - t.work_s_spent();
  Termination own(t.stop_token());
  if (std::isfinite(work)) own.set_deadline(std::max(work, 1e-9), "nominal search time");
  double end = stats.start_length_mm;
  Strip strip(shapes, free, items, usable, end, seed * 7919, own);
  strip.add_movers(std::max(1, workers));
  const std::vector<Item> found = strip.search(end, stats, progress);
  t.charge(0, own.work_s_spent());
  t.should_end();  // records what ended the work, for the report
  for (const Item& it : found) {
    Placement& p = nest.placements[it.placement];
    const Shape& s = shape_of(shapes, it.part, it.turn);
    p.rotation_deg = s.rotation_deg;
    p.mirrored = s.mirrored;
    p.translate_mm = it.at;
  }
  nest.used_length_mm[static_cast<std::size_t>(last)] = end;
  return stats;
}

NestResult nest(const NestRequest& r, Termination& t, std::uint64_t seed, int workers, StripSearchStats* stats,
                NestProgress* progress) {
  const ShapeSet shapes = shapes_of(r);
  if (!std::isfinite(t.deadline_s())) return bottom_left_nest(r, shapes, t, seed);
  // The fills' restarts matter where they may save a sheet; on one sheet the search does better.
  // Their share of the deadline counts the first fill: none when it took that much already.
  Termination first(t);
  first.set_budget(1, "fills");
  const NestResult one = bottom_left_nest(r, shapes, first, seed);
  const double share = (one.sheets_used > 1 || !one.unplaced.empty() ? 0.1 : 0.02) * t.deadline_s() - first.work_s_spent();
  NestResult n = one;
  if (share > 0) {
    Termination fill(t);
    fill.set_deadline(share, "nominal search time");
    n = bottom_left_nest(r, shapes, fill, seed, &one);
  }
  if (progress) {
    progress->sheets = n.sheets_used;
    progress->offer_length(n.last_length_mm());
  }
  const StripSearchStats s = shorten_last_sheet(r, shapes, n, t, seed, workers, progress);
  if (progress) progress->share.finish();
  if (stats) *stats = s;
  return n;
}

}  // namespace machplan::nesting
