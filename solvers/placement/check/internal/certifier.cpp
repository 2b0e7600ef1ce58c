#include "solvers/placement/check/internal/certifier.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <mutex>
#include <queue>
#include <thread>

#include <tbb/concurrent_priority_queue.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "solvers/placement/machines/internal/bounds.h"

namespace machplan::placement {

namespace {
// report() walks the subtrees at this depth of the pose tree, each on its own.
constexpr int kReportSplitDepth = 5;

// A tree node to open, with the constraints still to settle below it; smallest key first.
struct Item {
  double key;
  int node;
  Mask mask;
};
struct LaterItem {
  bool operator()(const Item& a, const Item& b) const { return a.key > b.key; }
};
}  // namespace

// Full evaluations at one placement by pose index, shared by the threads of a scan and kept
// for the next scan at the same placement (a report right after the decision that certified
// the placement reuses them). A slot is written once per placement by the thread that claims
// it; the others compute their own copy meanwhile.
struct Certifier::Cache {
  static constexpr unsigned kWriting = ~0u;
  int stride = 0;
  std::vector<double> values;
  std::unique_ptr<std::atomic<unsigned>[]> gen;
  unsigned current = 1;
  Where key;
  bool valid = false;

  Cache(long n, int s) : stride(s), values(static_cast<std::size_t>(n) * s), gen(new std::atomic<unsigned>[n]) {
    for (long i = 0; i < n; ++i) gen[i].store(0, std::memory_order_relaxed);
    size = n;
  }
  long size = 0;
  void begin(const Where& w) {
    if (valid && w == key) return;
    key = w;
    valid = true;
    if (++current == kWriting) {
      for (long i = 0; i < size; ++i) gen[i].store(0, std::memory_order_relaxed);
      current = 1;
    }
  }
  template <class F>
  const double* get(long i, double* scratch, F&& compute) {
    unsigned g = gen[i].load(std::memory_order_acquire);
    double* slot = &values[static_cast<std::size_t>(i) * stride];
    if (g == current) return slot;
    compute(scratch);
    if (g != kWriting && gen[i].compare_exchange_strong(g, kWriting, std::memory_order_acq_rel)) {
      std::copy(scratch, scratch + stride, slot);
      gen[i].store(current, std::memory_order_release);
    }
    return scratch;
  }
};

// One scan's settings and record.
struct Certifier::Scan {
  enum class Mode { decide, report, probe } mode = Mode::decide;
  const Certifier& c;
  Where where;
  Ball ball;
  Mask mask = 0;       // constraints this scan settles
  Mask eval_mask = 0;  // constraints evaluated at poses
  std::vector<double> thr_ok;  // decide, probe: what a stretch must be shown to reach
  std::vector<Minimum> best;   // report
  bool poses_only = false;     // probe: tool poses only
  long budget = -1;            // probe: nodes to open before giving up
  bool use_cache = true;
  Spot fail;
  Termination& term;
  WorkCounts& counts;

  Scan(const Certifier& cert, Mode m, const Where& w, const Ball& b, Mask settle, Termination& t, WorkCounts& k)
      : mode(m), c(cert), where(w), ball(b), mask(settle & cert.model_.all_mask()), term(t), counts(k) {
    eval_mask = cert.model_.all_mask();
    const int n = cert.model_.count();
    if (mode == Mode::report) {
      best.assign(n, Minimum{});
      return;
    }
    thr_ok.resize(n);
    const Motion global = cert.ball_motion(ball, cert.tree_.radius_mm());
    for (int k = 0; k < n; ++k) {
      const double limit = cert.model_.constraints()[k].limit;
      thr_ok[k] = limit + (ball.point() ? 0.0 : cert.model_.fall(k, nullptr, global));
    }
  }

  double need(int k) const {
    if (mode != Mode::report) return thr_ok[k];
    // While nothing below the limit has been seen, nothing that could be below it is left
    // unexamined, so a report that finds every kind free is also a proof.
    const Constraint& con = c.model_.constraints()[k];
    const double b = best[k].value;
    // Nothing met yet (or nothing to meet: a constraint with no parts in this scene).
    if (std::isinf(b)) return con.limit;
    const double need = b - report_margin(b, con.limit, con.report_tolerance);
    // Plain clearances are distances, never below 0: a need at or below 0 is met everywhere (a
    // huge tool touching the workpiece at every pose).
    if (con.distance && !con.signed_distance && need <= 0) return -kInf;
    return b >= con.limit ? std::max(need, con.limit) : need;
  }

  // Exact values v at pose i, t: a report records minima; a decision fails on a value deep
  // enough to condemn the ball.
  bool check_exact(long i, double t, const double* v, Mask m, const PathPose& pose) {
    for (int k = 0; k < c.model_.count(); ++k) {
      if (!(m & bit(k))) continue;
      if (mode == Mode::report) {
        if (v[k] < best[k].value) best[k] = {v[k], i, t};
      } else if (v[k] <= c.fail_threshold(k, v, pose, ball)) {
        fail = {i, t, k, v[k], true};
        return false;
      }
    }
    return true;
  }

  const double* values_at(long i, double* scratch, PoseEvaluator& e) {
    auto compute = [&](double* out) { c.evaluate(c.tree_.pose(i), where, eval_mask, out, e, term, counts); };
    if (!use_cache) {
      compute(scratch);
      return scratch;
    }
    return c.cache_->get(i, scratch, compute);
  }

  bool interval(long i, double t0, double t1, const double* v0, const double* v1, Mask m, PoseEvaluator& e, int depth) {
    const int n = c.model_.count();
    const Motion step = c.tree_.step(i, t1 - t0);
    double worst_bound = kInf;
    int worst = -1;
    for (int k = 0; k < n; ++k) {
      if (!(m & bit(k))) continue;
      // Each end's bound holds over the whole stretch (its motion reaches the other end).
      const double d = std::min(c.model_.fall(k, v0, step), c.model_.fall(k, v1, step));
      // Along the stretch the value cannot drop below this (it falls at most d in total).
      const double bound = (v0[k] + v1[k] - d) / 2;
      if (bound >= need(k) || std::min(v0[k], v1[k]) - d >= need(k)) {
        m &= ~bit(k);
        continue;
      }
      if (bound < worst_bound) worst_bound = bound, worst = k;
    }
    if (!m) return true;
    if (depth >= kMaxIntervalDepth) {
      // Could not be proven to the required precision: report it, never assume it free.
      if (mode == Mode::report) {
        for (int k = 0; k < n; ++k)
          if (m & bit(k)) {
            const double bound = (v0[k] + v1[k] - std::min(c.model_.fall(k, v0, step), c.model_.fall(k, v1, step))) / 2;
            if (bound < best[k].value) best[k] = {bound, i, (t0 + t1) / 2};
          }
        return true;
      }
      fail = {i, (t0 + t1) / 2, worst, worst_bound, false};
      return false;
    }
    const double tm = (t0 + t1) / 2;
    std::vector<double> vm(c.model_.stride());
    const PathPose pm = c.tree_.at(i, tm);
    // Only what is still unsettled on this stretch.
    c.evaluate(pm, where, m, vm.data(), e, term, counts);
    ++counts.interpolated_poses;
    if (!check_exact(i, tm, vm.data(), m, pm)) return false;
    return interval(i, t0, tm, v0, vm.data(), m, e, depth + 1) && interval(i, tm, t1, vm.data(), v1, m, e, depth + 1);
  }

  // Opens one node: false on a refutation; pushes what remains to settle below it.
  template <class Push>
  bool open(const Item& it, PoseEvaluator& e, std::vector<double>& a, std::vector<double>& b, Push&& push) {
    ++counts.stretches;
    const PoseTree::Node& node = c.tree_.nodes()[it.node];
    Mask m = it.mask;
    if (node.leaf()) {
      const long i = node.left;
      const double* v0 = values_at(i, a.data(), e);
      if (v0 != a.data()) std::copy(v0, v0 + c.model_.stride(), a.begin());
      if (!check_exact(i, 0, a.data(), m, c.tree_.pose(i))) return false;
      const double* v1 = values_at(i + 1, b.data(), e);
      if (v1 != b.data()) std::copy(v1, v1 + c.model_.stride(), b.begin());
      if (!check_exact(i + 1, 0, b.data(), m, c.tree_.pose(i + 1))) return false;
      if (poses_only) return true;
      return interval(i, 0.0, 1.0, a.data(), b.data(), m, e, 0);
    }
    const double* v = values_at(node.centre, a.data(), e);
    if (!check_exact(node.centre, 0, v, m, c.tree_.pose(node.centre))) return false;
    const Motion motion = c.tree_.node_motion(node);
    double key = kInf;
    for (int k = 0; k < c.model_.count(); ++k) {
      if (!(m & bit(k))) continue;
      const double low = v[k] - c.model_.fall(k, v, motion);
      const double nd = need(k);
      if (low >= nd) {
        m &= ~bit(k);
        ++counts.proven_by_bound;
      } else {
        key = std::min(key, (low - nd) * c.model_.constraints()[k].order_weight);
      }
    }
    if (!m) return true;
    push(Item{key, node.left, m});
    push(Item{key, node.right, m});
    return true;
  }

  // Best first from one node on this thread.
  bool walk(int root, PoseEvaluator& e) {
    std::priority_queue<Item, std::vector<Item>, LaterItem> open_items;
    open_items.push({-kInf, root, mask});
    std::vector<double> a(c.model_.stride()), b(c.model_.stride());
    while (!open_items.empty()) {
      if (budget >= 0 && budget-- == 0) return true;
      const Item it = open_items.top();
      open_items.pop();
      if (!open(it, e, a, b, [&](const Item& x) { open_items.push(x); })) return false;
    }
    return true;
  }

  // A path of one pose.
  bool single(PoseEvaluator& e) {
    std::vector<double> a(c.model_.stride());
    const double* v = values_at(0, a.data(), e);
    if (!check_exact(0, 0, v, mask, c.tree_.pose(0))) return false;
    for (int k = 0; k < c.model_.count(); ++k)
      if ((mask & bit(k)) && mode != Mode::report && v[k] < thr_ok[k]) {
        fail = {0, 0, k, v[k], false};
        return false;
      }
    return true;
  }
};

Certifier::Certifier(const MachineModel& model, const PoseTree& tree, double workpiece_radius_mm)
    : model_(model), tree_(tree), wp_radius_(workpiece_radius_mm),
      cache_(std::make_shared<Cache>(tree.size(), model.stride())) {}

Motion Certifier::ball_motion(const Ball& ball, double r, double lean) const {
  const double h = ball.turn_deg * kDeg;
  const double pad = ball.pad_half_mm >= 0 ? std::min(ball.pad_half_mm, ball.radius_mm) : ball.radius_mm;
  // A turn h about the vertical moves the tip r h and turns an axis leaning `lean` (its sine)
  // from the vertical by at most h lean.
  return {ball.radius_mm + r * h, h * std::min(1.0, lean), h, ball.radius_mm + wp_radius_ * h, pad, false};
}

Motion Certifier::ball_motion(const Ball& ball, const PathPose& pose) const {
  return ball_motion(ball, pose.tip.head<2>().norm(), pose.axis.head<2>().norm());
}

double Certifier::fail_threshold(int c, const double* v, const PathPose& pose, const Ball& ball) const {
  const double limit = model_.constraints()[c].limit;
  // A single placement fails below its limit (a value exactly at it is still allowed).
  if (ball.point()) return std::nextafter(limit, -kInf);
  return limit - model_.fall(c, v, ball_motion(ball, pose));
}

void Certifier::evaluate(const PathPose& pose, const Where& where, Mask mask, double* v, PoseEvaluator& e,
                         Termination& term, WorkCounts& counts) const {
  term.charge(1);
  if (term.should_end()) throw WorkEnded{term.reason()};
  ++counts.exact_queries;
  e.evaluate(pose, where, mask, v);
}

std::optional<BoxRange> Certifier::box_range(int c, const PathPose& pose, const Where& centre, const Eigen::Vector3d& half,
                                             PoseEvaluator& e, Termination& term, WorkCounts& counts) const {
  if (term.should_end()) throw WorkEnded{term.reason()};
  std::optional<BoxRange> r = e.box_range(c, pose, centre, half);
  if (r) {
    term.charge(1);
    ++counts.exact_queries;
  }
  return r;
}

bool Certifier::decide(const Where& centre, const Ball& ball, Mask mask, Termination& term, const Evaluator& evaluator,
                       WorkCounts& counts, Spot* failure) {
  Scan s(*this, Scan::Mode::decide, centre, ball, mask, term, counts);
  cache_->begin(centre);
  bool ok = true;
  if (tree_.size() == 1) {
    ok = s.single(evaluator());
  } else {
    // Every worker opens nodes from one queue, deepest deficit first; the first refutation
    // stops them all.
    tbb::concurrent_priority_queue<Item, LaterItem> q;
    std::atomic<long> pending{1};
    std::atomic<bool> failed{false};
    std::mutex fail_mutex;
    std::exception_ptr error;
    q.push({-kInf, 0, s.mask});
    const int workers = std::max(1, tbb::this_task_arena::max_concurrency());
    tbb::parallel_for(0, workers, [&](int) {
      PoseEvaluator& e = evaluator();
      Scan local(*this, Scan::Mode::decide, centre, ball, mask, term, counts);
      std::vector<double> a(model_.stride()), b(model_.stride());
      auto push = [&](const Item& x) {
        pending.fetch_add(1, std::memory_order_relaxed);
        q.push(x);
      };
      while (!failed.load(std::memory_order_relaxed)) {
        Item it;
        if (!q.try_pop(it)) {
          if (pending.load(std::memory_order_acquire) == 0) break;
          std::this_thread::yield();
          continue;
        }
        bool good = true;
        try {
          good = local.open(it, e, a, b, push);
        } catch (...) {
          // The work ended (or broke): stop every worker, then rethrow on the caller's thread.
          const std::lock_guard<std::mutex> lock(fail_mutex);
          if (!error) error = std::current_exception();
          failed.store(true);
        }
        if (!good) {
          const std::lock_guard<std::mutex> lock(fail_mutex);
          if (!failed.load()) s.fail = local.fail;
          failed.store(true);
        }
        pending.fetch_sub(1, std::memory_order_acq_rel);
      }
    });
    if (error) std::rethrow_exception(error);
    ok = !failed.load();
  }
  if (!ok && failure) *failure = s.fail;
  return ok;
}

bool Certifier::probe(const Where& centre, const Ball& ball, Mask cheap, Mask mask, Termination& term,
                      const Evaluator& evaluator, WorkCounts& counts, Spot* found) {
  // Looks only for an interference deep enough to condemn the whole ball, at tool poses, with
  // a bounded effort: first the cheap constraints (the limits), then the others. Nodes whose
  // lower bounds stay above the failure threshold are dropped at once.
  if (tree_.size() < 2) return true;
  constexpr long kProbeBudget = 30;
  for (const Mask m : {cheap, mask & ~cheap}) {
    if (!m) continue;
    Scan s(*this, Scan::Mode::probe, centre, ball, m, term, counts);
    s.poses_only = true;
    s.use_cache = false;
    s.eval_mask = m;
    s.budget = kProbeBudget;
    const Motion global = ball_motion(ball, tree_.radius_mm());
    for (int k = 0; k < model_.count(); ++k)
      s.thr_ok[k] = ball.point() ? std::nextafter(model_.constraints()[k].limit, -kInf)
                                 : model_.constraints()[k].limit - model_.fall(k, nullptr, global);
    if (!s.walk(0, evaluator()) && s.fail.exact) {
      if (found) *found = s.fail;
      return false;
    }
  }
  return true;
}

std::vector<Minimum> Certifier::report(const Where& where, Termination& term, const Evaluator& evaluator,
                                       WorkCounts& counts) {
  cache_->begin(where);
  const Mask all = model_.all_mask();
  if (tree_.size() == 1) {
    Scan s(*this, Scan::Mode::report, where, {}, all, term, counts);
    s.single(evaluator());
    return s.best;
  }
  // A fixed set of subtrees, each pinning its own minima: the same figures for any number of
  // threads.
  const std::vector<int> roots = tree_.frontier(kReportSplitDepth);
  std::vector<std::vector<Minimum>> found(roots.size());
  tbb::parallel_for(std::size_t{0}, roots.size(), [&](std::size_t k) {
    Scan s(*this, Scan::Mode::report, where, {}, all, term, counts);
    s.walk(roots[k], evaluator());
    found[k] = std::move(s.best);
  });
  std::vector<Minimum> out(model_.count());
  for (const auto& f : found)
    for (int c = 0; c < model_.count(); ++c)
      if (f[c].value < out[c].value) out[c] = f[c];
  return out;
}

std::vector<Minimum> Certifier::dense(const Where& where, double step_mm, Termination& term, const Evaluator& evaluator,
                                      WorkCounts& counts, Progress* progress,
                                      const std::function<double(const PathPose&)>& extra) {
  const long n = tree_.size();
  const int stride = model_.stride(), count = model_.count() + (extra ? 1 : 0);
  constexpr long kChunk = 256;
  const long chunks = (n + kChunk - 1) / kChunk;
  std::vector<std::vector<Minimum>> found(chunks, std::vector<Minimum>(count));
  std::atomic<long> done{0};
  tbb::parallel_for(long{0}, chunks, [&](long ch) {
    PoseEvaluator& e = evaluator();
    std::vector<double> v(stride);
    auto visit = [&](long i, double t) {
      const PathPose pose = tree_.at(i, t);
      evaluate(pose, where, model_.all_mask(), v.data(), e, term, counts);
      for (int c = 0; c < model_.count(); ++c)
        if (v[c] < found[ch][c].value) found[ch][c] = {v[c], i, t};
      if (extra) {
        const double x = extra(pose);
        if (x < found[ch][count - 1].value) found[ch][count - 1] = {x, i, t};
      }
    };
    for (long i = ch * kChunk; i < std::min(n, (ch + 1) * kChunk); ++i) {
      if (i + 1 == n) {
        visit(i, 0.0);
        break;
      }
      const Motion m = tree_.step(i);
      const int sub = std::clamp(
          static_cast<int>(std::ceil(std::max({m.tip_mm / step_mm, m.axis_rad / (0.5 * kDeg), m.joints_rad / (0.5 * kDeg)}))), 1,
          100000);
      for (int k = 0; k < sub; ++k) visit(i, double(k) / sub);
    }
    report_progress(progress, static_cast<double>(done.fetch_add(1) + 1) / static_cast<double>(chunks));
  });
  std::vector<Minimum> out(count);
  for (const auto& f : found)
    for (int c = 0; c < count; ++c)
      if (f[c].value < out[c].value) out[c] = f[c];
  return out;
}

}  // namespace machplan::placement
