#include "solvers/placement/check/checker.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <iterator>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/task_arena.h>

#include "engine/common/error.h"
#include "solvers/placement/check/internal/certifier.h"
#include "solvers/placement/check/internal/class1.h"
#include "solvers/placement/check/internal/pose_tree.h"
#include "solvers/placement/report/internal/report.h"
#include "solvers/placement/scene/internal/workpiece.h"

namespace machplan::placement {

namespace {

std::vector<PathPose> poses_of(const Scene& scene) {
  std::vector<PathPose> poses(scene.tips_mm.size());
  for (std::size_t i = 0; i < poses.size(); ++i) poses[i] = {scene.tips_mm[i], scene.axes[i]};
  const auto refused = scene.model->prepare(poses);
  MACHPLAN_ASSERT(!refused, "the scene reader let through a pose the machine refuses: {}", refused ? refused->second : "");
  return poses;
}
}  // namespace

struct Checker::Impl {
  const Scene& scene;
  std::shared_ptr<const MachineModel> model;
  WorkpieceSolid wp;
  PoseTree tree;
  Class1Check class1;
  Certifier certifier;
  tbb::enumerable_thread_specific<std::unique_ptr<PoseEvaluator>> evaluators;
  tbb::enumerable_thread_specific<std::unique_ptr<Class1Check::Shapes>> class1_shapes;
  WorkCounts counts;
  std::mutex class1_mutex;
  std::map<double, Finding> class1_at;  // by rotation (deg)
  std::optional<Finding> ring;          // class 1 for every rotation at once (once asked)
  std::optional<Finding> axial;         // the parts of revolution alone, when the plate turns
  std::mutex axial_mutex;

  explicit Impl(const Scene& s)
      : scene(s), model(s.model), wp(s.model->workpiece()), tree(*model, poses_of(s)),
        class1(*model, tree, wp, s.safe_distance_mm), certifier(*model, tree, wp.radius_mm) {}

  PoseEvaluator& evaluator() {
    auto& e = evaluators.local();
    if (!e) e = model->evaluator();
    return *e;
  }
  Class1Check::Shapes& shapes() {
    auto& s = class1_shapes.local();
    if (!s) s = std::make_unique<Class1Check::Shapes>(class1.make_shapes());
    return *s;
  }
  Certifier::Evaluator eval_fn() {
    return [this]() -> PoseEvaluator& { return evaluator(); };
  }

  // The budget of one call: scene.search.max_pose_queries exact queries.
  struct Call {
    Termination term;
    Call(Termination& parent, long budget) : term(parent) {
      term.set_budget(budget, "exact pose queries (search.max_pose_queries in the scene)");
    }
  };
  long budget() const { return scene.search.max_pose_queries; }

  const Finding& class1_finding(double rotation_deg, Termination& parent) {
    {
      const std::lock_guard<std::mutex> lock(class1_mutex);
      const auto it = class1_at.find(rotation_deg);
      if (it != class1_at.end()) return it->second;
    }
    const Finding f = class1_walk(rotation_deg * kDeg, parent);
    const std::lock_guard<std::mutex> lock(class1_mutex);
    return class1_at.emplace(rotation_deg, f).first->second;
  }

  // Class 1 at a rotation (nullopt: for every rotation, through the ring). With a plate that
  // turns, the parts of revolution, which are the same at every rotation, are walked once, and
  // each rotation walks the plate parts alone; the finding is the closer of the two.
  Finding class1_walk(std::optional<double> rotation_rad, Termination& parent) {
    auto walk = [&](std::optional<double> rot, Class1Check::Parts which) {
      Call call(parent, budget());
      Class1Result r = class1.run(rot, call.term, [this]() -> Class1Check::Shapes& { return shapes(); }, which);
      counts.add(r.counts);
      r.finding.line = line_of(r.finding.pose);
      return r.finding;
    };
    if (!class1.has_ring()) return walk(0.0, Class1Check::Parts::all);
    {
      const std::lock_guard<std::mutex> lock(axial_mutex);
      if (!axial) axial = walk(0.0, Class1Check::Parts::axial);
    }
    const Finding plate = walk(rotation_rad, Class1Check::Parts::plate);
    return plate.clearance_mm < axial->clearance_mm ? plate : *axial;
  }

  int line_of(long pose) const {
    return pose >= 0 && pose < static_cast<long>(scene.lines.size()) ? scene.lines[pose] : 0;
  }

  Finding describe(int c, long pose, double t, const Where& where, double value) {
    Finding f;
    f.pose = pose;
    f.t = t;
    f.line = line_of(pose);
    f.clearance_mm = value;
    evaluator().describe(c, tree.at(pose, t), where, value, f);
    f.interferes = value < model->constraints()[c].limit;
    return f;
  }

  // The footprint on the table over a ball: its corners move at most `move`.
  Decision on_table(const Where& where, double move) const {
    const TableShape table = model->table();
    bool clear = true;
    for (const auto& corner : wp.footprint(where)) {
      const double m = table.margin(corner);
      if (m < -move - 1e-9) return Decision::infeasible;
      if (m < move - 1e-9) clear = false;
    }
    return clear ? Decision::feasible : Decision::unknown;
  }

  // Assembles a report from each constraint's minimum.
  CheckReport assemble(const Placement& p, const Where& where, const std::vector<Minimum>& mins, const Finding& c1) {
    CheckReport r;
    r.placement = p;
    const auto& cons = model->constraints();
    r.stroke_margin_mm = kInf;
    r.joint_margin_deg = kInf;
    for (int k = 0; k < kKindCount; ++k) r.kinds[k].clearance_mm = kInf;
    // Per kind: the worst broken constraint; when none is broken, the smallest clearance among
    // its distances (or its smallest margin when it has none).
    for (int kind = 0; kind < kKindCount; ++kind) {
      int pick = -1;
      double worst = kInf;
      bool broken = false, distances = false;
      for (int c = 0; c < model->count(); ++c)
        if (static_cast<int>(cons[c].kind) == kind && cons[c].distance && mins[c].pose >= 0) distances = true;
      for (int c = 0; c < model->count(); ++c) {
        if (static_cast<int>(cons[c].kind) != kind || mins[c].pose < 0) continue;
        const bool b = mins[c].value < cons[c].limit;
        const double score = (mins[c].value - cons[c].limit) * (cons[c].distance ? 1.0 : cons[c].order_weight);
        if (b && !broken) {
          broken = true, pick = c, worst = score;
        } else if (b == broken && (broken || cons[c].distance || !distances) && score < worst) {
          pick = c, worst = score;
        }
      }
      if (pick >= 0) r.kinds[kind] = describe(pick, mins[pick].pose, mins[pick].t, where, mins[pick].value);
    }
    for (int c = 0; c < model->count(); ++c) {
      if (cons[c].margin == Constraint::Margin::travel) r.stroke_margin_mm = std::min(r.stroke_margin_mm, mins[c].value);
      if (cons[c].margin == Constraint::Margin::joint) r.joint_margin_deg = std::min(r.joint_margin_deg, mins[c].value / kDeg);
    }
    r.kinds[static_cast<int>(Kind::workpiece_class1)] = c1;
    Finding& wpp = r.kinds[static_cast<int>(Kind::workpiece_peripheral)];
    wpp = Finding{};
    wpp.clearance_mm = kInf;
    for (int k = 0; k < model->placement_count(); ++k) {
      Finding f;
      const double v = evaluator().placement_value(k, where, kInf, &f);
      if (v < wpp.clearance_mm) {
        f.clearance_mm = v;
        f.interferes = v < scene.safe_distance_mm;
        wpp = f;
      }
    }
    r.on_table = on_table(where, 0.0) != Decision::infeasible;
    return r;
  }
};

Checker::Checker(const Scene& scene) : impl_(std::make_unique<Impl>(scene)) {}

Checker::~Checker() = default;

const Finding& Checker::class1(double rotation_deg, Termination& term) {
  if (!impl_->class1.has_ring()) return impl_->class1_finding(0.0, term);
  return impl_->class1_finding(rotation_deg, term);
}

const Finding& Checker::class1_every_rotation(Termination& term) {
  Impl& m = *impl_;
  if (!m.ring) {
    if (m.class1.has_ring()) {
      // Every rotation at once, through the ring the plate parts sweep.
      m.ring = m.class1_walk(std::nullopt, term);
    } else {
      // Nothing turns with the workpiece: one check holds for every rotation.
      m.ring = m.class1_finding(0.0, term);
    }
  }
  return *m.ring;
}

CheckCounts Checker::counts() const { return impl_->counts.get(); }
std::size_t Checker::pose_count() const { return static_cast<std::size_t>(impl_->tree.size()); }
const std::vector<PathPose>& Checker::poses() const { return impl_->tree.poses(); }
const Scene& Checker::scene() const { return impl_->scene; }

CheckReport Checker::report(const Placement& p, Termination& term) {
  Impl& m = *impl_;
  const CheckCounts before = m.counts.get();
  const Finding c1 = class1(p.rotation_deg, term);
  Impl::Call call(term, m.budget());
  const Where where = Where::of(p);
  const std::vector<Minimum> mins = m.certifier.report(where, call.term, m.eval_fn(), m.counts);
  CheckReport r = m.assemble(p, where, mins, c1);
  const CheckCounts after = m.counts.get();
  r.counts = {after.stretches - before.stretches, after.exact_queries - before.exact_queries,
              after.interpolated_poses - before.interpolated_poses, after.proven_by_bound - before.proven_by_bound};
  return r;
}

Decision Checker::decide_block(const Placement& centre, const Ball& ball, Finding* witness) {
  Impl& m = *impl_;
  const Where where = Where::of(centre);
  const double c = m.scene.safe_distance_mm;
  const double move = ball.radius_mm + m.wp.radius_mm * ball.turn_deg * kDeg;
  const Decision table = m.on_table(where, move);
  if (table == Decision::infeasible) {
    if (witness) {
      *witness = Finding{};
      witness->interferes = true;
      witness->what = "the workpiece overhangs the table";
      witness->evasion = -centre.offset().head<2>().normalized();
    }
    return Decision::infeasible;
  }
  bool all_clear = table == Decision::feasible;
  for (int k = 0; k < m.model->placement_count(); ++k) {
    Finding f;
    const double v = m.evaluator().placement_value(k, where, c + move, witness ? &f : nullptr);
    if (v <= c - move && !(move == 0 && v >= c)) {
      if (witness) {
        *witness = f;
        witness->interferes = true;
        witness->clearance_mm = v;
      }
      return Decision::infeasible;
    }
    if (v < c + move) all_clear = false;
  }
  return all_clear ? Decision::feasible : Decision::unknown;
}

Decision Checker::decide(const Placement& p, const Ball& ball, Termination& term, Finding* witness, Spot* spot,
                         bool peripherals_first) {
  Impl& m = *impl_;
  const Decision block = decide_block(p, ball, witness);
  if (block == Decision::infeasible) return Decision::infeasible;
  bool all_clear = block == Decision::feasible;
  if (ball.turn_deg == 0 || !class1_clear_every_rotation(term)) {
    const Finding& c1 = class1(p.rotation_deg, term);
    if (c1.interferes) {
      if (witness) *witness = c1;
      return Decision::infeasible;
    }
    if (ball.turn_deg > 0) all_clear = false;  // class 1 known at the centre's rotation only
  }
  Impl::Call call(term, m.budget());
  const Where where = Where::of(p);
  Mask periph = 0;
  for (int c = 0; c < m.model->count(); ++c)
    if (m.model->constraints()[c].kind == Kind::machine_peripheral) periph |= bit(c);
  Spot fail;
  bool ok = true;
  if (peripherals_first && periph) ok = m.certifier.decide(where, ball, periph, call.term, m.eval_fn(), m.counts, &fail);
  if (ok && m.certifier.decide(where, ball, m.model->all_mask(), call.term, m.eval_fn(), m.counts, &fail))
    return all_clear ? Decision::feasible : Decision::unknown;
  // Refused by an exact interference deep enough, or, at a single placement, by an interval
  // that could not be proven at the finest subdivision: the checker never calls free what it
  // could not prove.
  if (!fail.exact && !ball.point()) return Decision::unknown;
  if (spot) *spot = fail;
  if (witness) {
    *witness = m.describe(fail.constraint, fail.pose, fail.t, where, fail.value);
    witness->interferes = true;
  }
  return Decision::infeasible;
}

Decision Checker::probe(const Placement& p, const Ball& ball, Termination& term, Spot* spot) {
  Impl& m = *impl_;
  Mask cheap = 0, rest = 0;
  for (int c = 0; c < m.model->count(); ++c) {
    const Constraint& con = m.model->constraints()[c];
    if (con.cheap)
      cheap |= bit(c);
    else if (con.kind != Kind::workpiece_class2)
      rest |= bit(c);
  }
  Impl::Call call(term, m.budget());
  Spot found;
  if (!m.certifier.probe(Where::of(p), ball, cheap, cheap | rest, call.term, m.eval_fn(), m.counts, &found)) {
    if (spot) *spot = found;
    return Decision::infeasible;
  }
  return Decision::unknown;
}

Decision Checker::screen_spot(const Spot& s, const Placement& centre, const Ball& ball, Termination& term) {
  return screen_spot(s, Where::of(centre), ball, term);
}

Decision Checker::screen_spot(const Spot& s, const Where& centre, const Ball& ball, Termination& term,
                              SpotScreen* more) {
  Impl& m = *impl_;
  if (more) *more = SpotScreen{};
  const PathPose pose = m.tree.at(s.pose, s.t);
  const Constraint& con = m.model->constraints()[s.constraint];
  // For a constraint that keeps a pad rate, with `highest` bounding the value on the box's top
  // face: it falls by pad_rate for each mm lower (1e-9 mm of margin against rounding).
  auto condemn_below = [&](double highest) {
    if (more && con.pad_trend > 0 && con.pad_rate > 0) more->condemned_below_mm = (highest - con.limit) / con.pad_rate + 1e-9;
  };
  if (ball.box() && !ball.point()) {
    // A box: the model's own bounds over it at its middle rotation, where it has them, widened
    // by how far the turn to its other rotations can move the value (from any state).
    const Eigen::Vector3d half(ball.x_half_mm, ball.y_half_mm, ball.pad_half_mm);
    if (auto r = m.certifier.box_range(s.constraint, pose, centre, half, m.evaluator(), term, m.counts)) {
      if (ball.turn_deg > 0.0) {
        const double turn = m.model->fall(s.constraint, nullptr, m.certifier.ball_motion(Ball{0.0, ball.turn_deg, 0.0}, pose));
        r->lower -= turn, r->upper += turn;
      }
      if (r->upper < con.limit) return Decision::infeasible;
      if (r->lower >= con.limit) return Decision::feasible;
      // The box's highest value is on its top face for a constraint that rises with the pad.
      condemn_below(r->upper);
      if (more) std::copy(std::begin(r->spread_mm), std::end(r->spread_mm), more->spread_mm);
      return Decision::unknown;
    }
  }
  thread_local std::vector<double> v;
  v.resize(m.model->stride());
  // A constraint that changes with the pad in one direction is looked at on the box's top (or
  // bottom) face, where it is largest; the rest of the ball lies in x, y and the turn.
  Where at = centre;
  Ball flat = ball;
  if (con.pad_trend != 0 && ball.pad_half_mm > 0) {
    at.offset.z() += con.pad_trend * ball.pad_half_mm;
    flat.radius_mm = std::sqrt(std::max(0.0, ball.radius_mm * ball.radius_mm - ball.pad_half_mm * ball.pad_half_mm));
    flat.pad_half_mm = 0;
  }
  m.certifier.evaluate(pose, at, bit(s.constraint), v.data(), m.evaluator(), term, m.counts);
  const double value = v[s.constraint], limit = con.limit;
  const double fall = flat.point() ? 0.0 : m.model->fall(s.constraint, v.data(), m.certifier.ball_motion(flat, pose));
  const bool bad = ball.point() ? value < limit : value <= limit - fall;
  if (bad) return Decision::infeasible;
  condemn_below(value + fall);  // at most that anywhere on the top face
  if (flat.radius_mm != ball.radius_mm) {
    // Clear over the box: from the face looked at, across the box's height (the pad changes by
    // all of it) and width.
    const Ball whole{flat.radius_mm + 2 * ball.pad_half_mm, ball.turn_deg, 2 * ball.pad_half_mm};
    return value < limit + m.model->fall(s.constraint, v.data(), m.certifier.ball_motion(whole, pose)) ? Decision::unknown
                                                                                                      : Decision::feasible;
  }
  return value < limit + fall ? Decision::unknown : Decision::feasible;
}

CheckReport Checker::dense_check(const Placement& p, double step_mm, Termination& term, Progress* progress) {
  Impl& m = *impl_;
  const Where where = Where::of(p);
  const std::optional<double> rot = m.class1.has_ring() ? std::optional<double>(p.rotation_deg * kDeg) : std::optional<double>(0.0);
  auto extra = [&](const PathPose& pose) { return m.class1.exact(pose, rot, m.shapes(), nullptr); };
  std::vector<Minimum> mins = m.certifier.dense(where, step_mm, term, m.eval_fn(), m.counts, progress, extra);
  const Minimum c1 = mins.back();
  mins.pop_back();
  Finding f1;
  f1.clearance_mm = c1.value;
  f1.pose = c1.pose;
  f1.t = c1.t;
  f1.line = m.line_of(c1.pose);
  if (c1.pose >= 0 && std::isfinite(c1.value)) {
    std::string who;
    m.class1.exact(m.tree.at(c1.pose, c1.t), rot, m.shapes(), &who);
    f1.what = who + " / workpiece";
  } else {
    f1.what = "every part at least the safe distance away";
  }
  f1.interferes = c1.value < m.scene.safe_distance_mm;
  CheckReport r = m.assemble(p, where, mins, f1);
  r.counts = CheckCounts{};
  return r;
}

CheckResult check(const Scene& scene, const Placement& p, const CheckOptions& options, Termination& term,
                  Progress* progress) {
  options.validate();
  CheckResult out;
  out.dense = options.dense;
  out.poses = scene.tips_mm.size();
  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::this_task_arena::max_concurrency());
  arena.execute([&] {
    try {
      Checker checker(scene);
      out.report = options.dense ? checker.dense_check(p, options.dense_step_mm, term, progress) : checker.report(p, term);
      out.counts = checker.counts();
    } catch (const WorkEnded& e) {
      out.summary.status = status_of(e.reason);
      out.summary.message = e.reason == Termination::Reason::budget && !term.ended() ? budget_message(scene) : term.describe();
    }
  });
  write_check_summary(scene, out);
  return out;
}

void CheckOptions::validate() const {
  if (threads < 0 || threads > 1024) throw InputError::field("threads", fmt::format("{}: must lie within 0 .. 1024", threads));
  if (!(dense_step_mm >= 0.01 && dense_step_mm <= 1000))
    throw InputError::field("dense_step_mm", fmt::format("{} mm: must lie within 0.01 .. 1000", dense_step_mm));
}

}  // namespace machplan::placement
