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
#include "solvers/placement/check/internal/tool_change.h"
#include "solvers/placement/report/internal/report.h"
#include "solvers/placement/scene/internal/workpiece.h"

namespace machplan::placement {

namespace {

// The path's poses as the machine takes them. The rotary angles depend on the tool axis alone:
// they are taken along the whole path at once, so that a tool change does not restart the
// table's turns.
std::vector<PathPose> poses_of(const Scene& scene) {
  std::vector<PathPose> poses(scene.tips_mm.size());
  for (std::size_t i = 0; i < poses.size(); ++i) poses[i] = {scene.tips_mm[i], scene.axes[i]};
  const auto refused = scene.model->prepare(poses);
  MACHPLAN_ASSERT(!refused, "the scene reader let through a pose the machine refuses: {}", refused ? refused->second : "");
  return poses;
}

// Keeps the worse of two findings for one kind: an interference before a clearance, then the
// smaller clearance.
void keep_worse(Finding& into, const Finding& f) {
  if ((f.interferes && !into.interferes) || (f.interferes == into.interferes && f.clearance_mm < into.clearance_mm)) into = f;
}
}  // namespace

// One run of the path: the moves one tool makes between two tool changes, with the machine
// model built with that tool, its own pose tree, class-1 check and certifier. A path is
// continuous within a run; a tool change is no motion the certifier interpolates.
struct Checker::Run {
  std::shared_ptr<const MachineModel> model;
  std::size_t first = 0;  // the path index of its first pose
  int tool = 0;           // index into scene.tools
  const WorkpieceSolid& wp;  // the model's, which lives as long as `model`
  PoseTree tree;
  Class1Check class1;
  Certifier certifier;
  tbb::enumerable_thread_specific<std::unique_ptr<PoseEvaluator>> evaluators;
  tbb::enumerable_thread_specific<std::unique_ptr<Class1Check::Shapes>> class1_shapes;
  std::mutex class1_mutex;
  std::map<double, Finding> class1_at;  // by rotation (deg)
  std::optional<Finding> axial;         // the parts of revolution alone, when the plate turns
  std::mutex axial_mutex;

  // The moves of a tool change at one placement (tool_change.h): named by `change`, found at
  // the path index `first` (the first pose of the run it leads to).
  std::string change;

  Run(const Scene& s, const ToolRun& r, const std::vector<PathPose>& all)
      : Run(s, r.tool, r.first, std::vector<PathPose>(all.begin() + r.first, all.begin() + r.end)) {}
  Run(const Scene& s, int tool_index, std::size_t first_pose, std::vector<PathPose> poses)
      : model(s.tools[tool_index].model), first(first_pose), tool(tool_index), wp(model->workpiece()),
        tree(*model, std::move(poses)), class1(*model, tree, wp, s.safe_distance_mm),
        certifier(*model, tree, wp.radius_mm) {}

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
};

struct Checker::Impl {
  const Scene& scene;
  std::vector<std::unique_ptr<Run>> runs;
  std::vector<PathPose> joined;  // every run's poses in path order, when there are several
  WorkCounts counts;
  std::mutex class1_mutex;
  std::map<double, Finding> class1_at;  // every run's worst, by rotation (deg)
  std::optional<Finding> ring;          // class 1 for every rotation at once (once asked)

  explicit Impl(const Scene& s) : scene(s) {
    MACHPLAN_ASSERT(!s.runs.empty() && s.runs.front().first == 0 && s.runs.back().end == s.tips_mm.size(),
                    "the scene's runs do not cover its {} poses", s.tips_mm.size());
    {
      const std::vector<PathPose> all = poses_of(s);
      for (const ToolRun& r : s.runs) runs.push_back(std::make_unique<Run>(s, r, all));
    }
    if (runs.size() > 1)
      for (const auto& r : runs) joined.insert(joined.end(), r->tree.poses().begin(), r->tree.poses().end());
  }
  // The path's poses as the machines take them (rotary angles filled in).
  const std::vector<PathPose>& poses() const { return runs.size() > 1 ? joined : runs.front()->tree.poses(); }

  // The first run's model: for what no tool changes (the table, the placement-only checks).
  const MachineModel& machine() const { return *runs.front()->model; }
  Run& run_of(long pose) {
    std::size_t k = runs.size() - 1;
    while (k > 0 && static_cast<long>(runs[k]->first) > pose) --k;
    return *runs[k];
  }
  bool has_ring() const {
    for (const auto& r : runs)
      if (r->class1.has_ring()) return true;
    return false;
  }

  // The budget of one call: scene.search.max_pose_queries exact queries.
  struct Call {
    Termination term;
    Call(Termination& parent, long budget) : term(parent) {
      term.set_budget(budget, "exact pose queries (search.max_pose_queries in the scene)");
    }
  };
  long budget() const { return scene.search.max_pose_queries; }

  // Class 1 at a rotation over every run (nullopt: every rotation at once).
  Finding class1_all(std::optional<double> rotation_deg, Termination& term) {
    Finding worst;
    worst.clearance_mm = kInf;
    for (auto& r : runs) {
      const bool ring = r->class1.has_ring();
      const Finding f = rotation_deg || !ring ? run_class1(*r, ring ? *rotation_deg : 0.0, term)
                                              : run_class1_walk(*r, std::nullopt, term);
      keep_worse(worst, f);
    }
    return worst;
  }

  const Finding& run_class1(Run& run, double rotation_deg, Termination& parent) {
    {
      const std::lock_guard<std::mutex> lock(run.class1_mutex);
      const auto it = run.class1_at.find(rotation_deg);
      if (it != run.class1_at.end()) return it->second;
    }
    const Finding f = run_class1_walk(run, rotation_deg * kDeg, parent);
    const std::lock_guard<std::mutex> lock(run.class1_mutex);
    return run.class1_at.emplace(rotation_deg, f).first->second;
  }

  // Class 1 of a run at a rotation (nullopt: for every rotation, through the ring). With a
  // plate that turns, the parts of revolution, which are the same at every rotation, are
  // walked once, and each rotation walks the plate parts alone; the finding is the closer.
  Finding run_class1_walk(Run& run, std::optional<double> rotation_rad, Termination& parent) {
    auto walk = [&](std::optional<double> rot, Class1Check::Parts which) {
      Call call(parent, budget());
      Class1Result r = run.class1.run(rot, call.term, [&run]() -> Class1Check::Shapes& { return run.shapes(); }, which);
      counts.add(r.counts);
      return in_path(run, r.finding);
    };
    if (!run.class1.has_ring()) return walk(0.0, Class1Check::Parts::all);
    {
      const std::lock_guard<std::mutex> lock(run.axial_mutex);
      if (!run.axial) run.axial = walk(0.0, Class1Check::Parts::axial);
    }
    const Finding plate = walk(rotation_rad, Class1Check::Parts::plate);
    return plate.clearance_mm < run.axial->clearance_mm ? plate : *run.axial;
  }

  // Class 1 of a run at a rotation: a path run's is kept per rotation, a tool change's (whose
  // poses hold at one placement) is walked afresh.
  Finding class1_of(Run& run, double rotation_deg, Termination& term) {
    if (!run.change.empty()) return run_class1_walk(run, rotation_deg * kDeg, term);
    return run_class1(run, run.class1.has_ring() ? rotation_deg : 0.0, term);
  }

  // The path's runs, then the tool changes' at one placement.
  std::vector<Run*> with_changes(const std::vector<std::unique_ptr<Run>>& changes) const {
    std::vector<Run*> all;
    for (const auto& r : runs) all.push_back(r.get());
    for (const auto& r : changes) all.push_back(r.get());
    return all;
  }

  // A run's finding with its pose as a path index, its line, and its tool when the job has
  // several (a tool change's: the first pose after the change, and the move named).
  Finding in_path(const Run& run, Finding f) const {
    if (!run.change.empty()) {
      if (f.pose >= 0) f.pose = static_cast<long>(run.first), f.t = 0;
      if (!f.what.empty()) f.what += " (" + run.change + ")";
    } else {
      if (f.pose >= 0) f.pose += static_cast<long>(run.first);
      if (scene.tools.size() > 1 && !f.what.empty()) f.what += " (" + scene.tools[run.tool].name + ")";
    }
    f.line = line_of(f.pose);
    return f;
  }

  // The tool changes' moves at a placement, one run out and one in per change; none when the
  // machine names no change position.
  std::vector<std::unique_ptr<Run>> change_runs(const Placement& p) const {
    std::vector<std::unique_ptr<Run>> out;
    if (!scene.tool_change) return out;
    const Where where = Where::of(p);
    for (std::size_t k = 1; k < scene.runs.size(); ++k) {
      ChangeMoves m = change_moves(scene, k, where, poses()[scene.runs[k - 1].end - 1], poses()[scene.runs[k].first]);
      const ToolRun &from = scene.runs[k - 1], &to = scene.runs[k];
      const std::string& a = scene.tools[from.tool].name;
      const std::string& b = scene.tools[to.tool].name;
      for (int leg = 0; leg < 2; ++leg) {
        const int tool = leg == 0 ? from.tool : to.tool;
        std::vector<PathPose>& poses = leg == 0 ? m.out : m.in;
        // Rotary angles come with the poses (the path's own, and zero at the change position).
        out.push_back(std::make_unique<Run>(scene, tool, to.first, std::move(poses)));
        out.back()->change = leg == 0 ? fmt::format("{} to the tool change before {}", a, b)
                                      : fmt::format("{} from the tool change", b);
      }
    }
    return out;
  }

  int line_of(long pose) const {
    return pose >= 0 && pose < static_cast<long>(scene.lines.size()) ? scene.lines[pose] : 0;
  }

  // `pose` is the run's own index.
  Finding describe(Run& run, int c, long pose, double t, const Where& where, double value) {
    Finding f;
    f.pose = pose;
    f.t = t;
    f.clearance_mm = value;
    run.evaluator().describe(c, run.tree.at(pose, t), where, value, f);
    f.interferes = value < run.model->constraints()[c].limit;
    return in_path(run, f);
  }

  // The footprint on the table over a ball: its corners move at most `move`.
  Decision on_table(const Where& where, double move) const {
    const TableShape table = machine().table();
    bool clear = true;
    for (const auto& corner : runs.front()->wp.footprint(where)) {
      const double m = table.margin(corner);
      if (m < -move - 1e-9) return Decision::infeasible;
      if (m < move - 1e-9) clear = false;
    }
    return clear ? Decision::feasible : Decision::unknown;
  }

  // A run's report from each constraint's minimum (the placement-only checks aside).
  CheckReport assemble_run(Run& run, const Placement& p, const Where& where, const std::vector<Minimum>& mins,
                           const Finding& c1) {
    CheckReport r;
    r.placement = p;
    const MachineModel& model = *run.model;
    const auto& cons = model.constraints();
    r.stroke_margin_mm = kInf;
    r.joint_margin_deg = kInf;
    for (int k = 0; k < kKindCount; ++k) r.kinds[k].clearance_mm = kInf;
    // Per kind: the worst broken constraint; when none is broken, the smallest clearance among
    // its distances (or its smallest margin when it has none).
    for (int kind = 0; kind < kKindCount; ++kind) {
      int pick = -1;
      double worst = kInf;
      bool broken = false, distances = false;
      for (int c = 0; c < model.count(); ++c)
        if (static_cast<int>(cons[c].kind) == kind && cons[c].distance && mins[c].pose >= 0) distances = true;
      for (int c = 0; c < model.count(); ++c) {
        if (static_cast<int>(cons[c].kind) != kind || mins[c].pose < 0) continue;
        const bool b = mins[c].value < cons[c].limit;
        const double score = (mins[c].value - cons[c].limit) * (cons[c].distance ? 1.0 : cons[c].order_weight);
        if (b && !broken) {
          broken = true, pick = c, worst = score;
        } else if (b == broken && (broken || cons[c].distance || !distances) && score < worst) {
          pick = c, worst = score;
        }
      }
      if (pick >= 0) r.kinds[kind] = describe(run, pick, mins[pick].pose, mins[pick].t, where, mins[pick].value);
    }
    for (int c = 0; c < model.count(); ++c) {
      if (cons[c].margin == Constraint::Margin::travel) r.stroke_margin_mm = std::min(r.stroke_margin_mm, mins[c].value);
      if (cons[c].margin == Constraint::Margin::joint) r.joint_margin_deg = std::min(r.joint_margin_deg, mins[c].value / kDeg);
    }
    r.kinds[static_cast<int>(Kind::workpiece_class1)] = c1;
    return r;
  }

  // The job's report from its runs' reports: per kind the worst, per tool its tightest
  // clearance, then the placement-only checks.
  CheckReport assemble(const Where& where, const std::vector<CheckReport>& per_run, const std::vector<Run*>& of) {
    CheckReport r = per_run.front();
    for (std::size_t k = 1; k < per_run.size(); ++k) {
      for (int kind = 0; kind < kKindCount; ++kind) keep_worse(r.kinds[kind], per_run[k].kinds[kind]);
      r.stroke_margin_mm = std::min(r.stroke_margin_mm, per_run[k].stroke_margin_mm);
      r.joint_margin_deg = std::min(r.joint_margin_deg, per_run[k].joint_margin_deg);
    }
    r.tools.clear();
    for (const SceneTool& t : scene.tools) r.tools.push_back({t.name, 0, Finding{}, Kind::self});
    for (auto& t : r.tools) t.tightest.clearance_mm = kInf;
    for (std::size_t k = 0; k < per_run.size(); ++k) {
      ToolClearance& t = r.tools[of[k]->tool];
      if (of[k]->change.empty()) t.poses += static_cast<long>(of[k]->tree.size());
      for (int kind = 0; kind < kKindCount; ++kind) {
        const Finding& f = per_run[k].kinds[kind];
        if (kind == static_cast<int>(Kind::workpiece_peripheral) || !std::isfinite(f.clearance_mm)) continue;
        if (f.clearance_mm < t.tightest.clearance_mm) t.tightest = f, t.kind = static_cast<Kind>(kind);
      }
    }
    Finding& wpp = r.kinds[static_cast<int>(Kind::workpiece_peripheral)];
    wpp = Finding{};
    wpp.clearance_mm = kInf;
    for (int k = 0; k < machine().placement_count(); ++k) {
      Finding f;
      const double v = runs.front()->evaluator().placement_value(k, where, kInf, &f);
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
  Impl& m = *impl_;
  const double rot = m.has_ring() ? rotation_deg : 0.0;
  {
    const std::lock_guard<std::mutex> lock(m.class1_mutex);
    const auto it = m.class1_at.find(rot);
    if (it != m.class1_at.end()) return it->second;
  }
  const Finding f = m.class1_all(rot, term);
  const std::lock_guard<std::mutex> lock(m.class1_mutex);
  return m.class1_at.emplace(rot, f).first->second;
}

const Finding& Checker::class1_every_rotation(Termination& term) {
  Impl& m = *impl_;
  // With a plate that turns, every rotation at once through the ring the plate parts sweep;
  // with nothing turning with the workpiece, one check holds for every rotation.
  if (!m.ring) m.ring = m.has_ring() ? m.class1_all(std::nullopt, term) : class1(0.0, term);
  return *m.ring;
}

CheckCounts Checker::counts() const { return impl_->counts.get(); }
std::size_t Checker::pose_count() const { return impl_->poses().size(); }
const std::vector<PathPose>& Checker::poses() const { return impl_->poses(); }
const Scene& Checker::scene() const { return impl_->scene; }
const std::string& Checker::constraint_name(const Spot& spot) const {
  return impl_->run_of(spot.pose).model->constraints()[spot.constraint].name;
}

CheckReport Checker::report(const Placement& p, Termination& term) {
  Impl& m = *impl_;
  const CheckCounts before = m.counts.get();
  Impl::Call call(term, m.budget());
  const Where where = Where::of(p);
  const auto changes = m.change_runs(p);
  const std::vector<Run*> of = m.with_changes(changes);
  std::vector<CheckReport> per_run;
  for (Run* run : of) {
    const Finding c1 = m.class1_of(*run, p.rotation_deg, term);
    const std::vector<Minimum> mins = run->certifier.report(where, call.term, run->eval_fn(), m.counts);
    per_run.push_back(m.assemble_run(*run, p, where, mins, c1));
  }
  CheckReport r = m.assemble(where, per_run, of);
  const CheckCounts after = m.counts.get();
  r.counts = {after.stretches - before.stretches, after.exact_queries - before.exact_queries,
              after.interpolated_poses - before.interpolated_poses, after.proven_by_bound - before.proven_by_bound};
  return r;
}

Decision Checker::decide_block(const Placement& centre, const Ball& ball, Finding* witness) {
  Impl& m = *impl_;
  const Where where = Where::of(centre);
  const double c = m.scene.safe_distance_mm;
  const double move = ball.radius_mm + m.runs.front()->wp.radius_mm * ball.turn_deg * kDeg;
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
  for (int k = 0; k < m.machine().placement_count(); ++k) {
    Finding f;
    const double v = m.runs.front()->evaluator().placement_value(k, where, c + move, witness ? &f : nullptr);
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
  // One run's constraints in `mask`: nullopt when certified, else the decision (infeasible, or
  // unknown over a ball where an interval could not be proven).
  auto certify = [&](Run& run, Mask mask) -> std::optional<Decision> {
    Spot fail;
    if (run.certifier.decide(where, ball, mask, call.term, run.eval_fn(), m.counts, &fail)) return std::nullopt;
    // Refused by an exact interference deep enough, or, at a single placement, by an interval
    // that could not be proven at the finest subdivision: the checker never calls free what it
    // could not prove.
    if (!fail.exact && !ball.point()) return Decision::unknown;
    if (witness) {
      *witness = m.describe(run, fail.constraint, fail.pose, fail.t, where, fail.value);
      witness->interferes = true;
    }
    fail.pose += static_cast<long>(run.first);
    // A spot on a tool change holds at this placement alone: nothing the searches could learn.
    if (!run.change.empty()) fail = Spot{}, fail.tool_change = true;
    if (spot) *spot = fail;
    return Decision::infeasible;
  };
  // Every run's peripheral constraints first (when asked), then all of every run.
  for (const bool periph_pass : {true, false}) {
    if (periph_pass && !peripherals_first) continue;
    for (auto& run : m.runs) {
      Mask mask = run->model->all_mask();
      if (periph_pass) {
        mask = 0;
        for (int c = 0; c < run->model->count(); ++c)
          if (run->model->constraints()[c].kind == Kind::machine_peripheral) mask |= bit(c);
        if (!mask) continue;
      }
      if (const auto d = certify(*run, mask)) return *d;
    }
  }
  if (!m.scene.tool_change || m.scene.runs.size() < 2) return all_clear ? Decision::feasible : Decision::unknown;
  // The tool changes' moves, which are fixed to the table rather than to the workpiece, are
  // certified at single placements only, each with its class 1.
  if (!ball.point()) return Decision::unknown;
  for (auto& run : m.change_runs(p)) {
    const Finding c1 = m.class1_of(*run, p.rotation_deg, term);
    if (c1.interferes) {
      if (witness) *witness = c1;
      if (spot) *spot = Spot{}, spot->tool_change = true;
      return Decision::infeasible;
    }
    if (const auto d = certify(*run, run->model->all_mask())) return *d;
  }
  return all_clear ? Decision::feasible : Decision::unknown;
}

Decision Checker::probe(const Placement& p, const Ball& ball, Termination& term, Spot* spot) {
  Impl& m = *impl_;
  Impl::Call call(term, m.budget());
  for (auto& run : m.runs) {
    Mask cheap = 0, rest = 0;
    for (int c = 0; c < run->model->count(); ++c) {
      const Constraint& con = run->model->constraints()[c];
      if (con.cheap)
        cheap |= bit(c);
      else if (con.kind != Kind::workpiece_class2)
        rest |= bit(c);
    }
    Spot found;
    if (!run->certifier.probe(Where::of(p), ball, cheap, cheap | rest, call.term, run->eval_fn(), m.counts, &found)) {
      found.pose += static_cast<long>(run->first);
      if (spot) *spot = found;
      return Decision::infeasible;
    }
  }
  return Decision::unknown;
}

Decision Checker::screen_spot(const Spot& s, const Placement& centre, const Ball& ball, Termination& term) {
  return screen_spot(s, Where::of(centre), ball, term);
}

Decision Checker::screen_spot(const Spot& s, const Where& centre, const Ball& ball, Termination& term,
                              SpotScreen* more) {
  Impl& m = *impl_;
  Run& run = m.run_of(s.pose);
  const MachineModel& model = *run.model;
  if (more) *more = SpotScreen{};
  const PathPose pose = run.tree.at(s.pose - static_cast<long>(run.first), s.t);
  const Constraint& con = model.constraints()[s.constraint];
  // For a constraint that keeps a pad rate, with `highest` bounding the value on the box's top
  // face: it falls by pad_rate for each mm lower (1e-9 mm of margin against rounding).
  auto condemn_below = [&](double highest) {
    if (more && con.pad_trend > 0 && con.pad_rate > 0) more->condemned_below_mm = (highest - con.limit) / con.pad_rate + 1e-9;
  };
  if (ball.box() && !ball.point()) {
    // A box: the model's own bounds over it at its middle rotation, where it has them, widened
    // by how far the turn to its other rotations can move the value (from any state).
    const Eigen::Vector3d half(ball.x_half_mm, ball.y_half_mm, ball.pad_half_mm);
    if (auto r = run.certifier.box_range(s.constraint, pose, centre, half, run.evaluator(), term, m.counts)) {
      if (ball.turn_deg > 0.0) {
        const double turn = model.fall(s.constraint, nullptr, run.certifier.ball_motion(Ball{0.0, ball.turn_deg, 0.0}, pose));
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
  v.resize(model.stride());
  // A constraint that changes with the pad in one direction is looked at on the box's top (or
  // bottom) face, where it is largest; the rest of the ball lies in x, y and the turn.
  Where at = centre;
  Ball flat = ball;
  if (con.pad_trend != 0 && ball.pad_half_mm > 0) {
    at.offset.z() += con.pad_trend * ball.pad_half_mm;
    flat.radius_mm = std::sqrt(std::max(0.0, ball.radius_mm * ball.radius_mm - ball.pad_half_mm * ball.pad_half_mm));
    flat.pad_half_mm = 0;
  }
  run.certifier.evaluate(pose, at, bit(s.constraint), v.data(), run.evaluator(), term, m.counts);
  const double value = v[s.constraint], limit = con.limit;
  const double fall = flat.point() ? 0.0 : model.fall(s.constraint, v.data(), run.certifier.ball_motion(flat, pose));
  const bool bad = ball.point() ? value < limit : value <= limit - fall;
  if (bad) return Decision::infeasible;
  condemn_below(value + fall);  // at most that anywhere on the top face
  if (flat.radius_mm != ball.radius_mm) {
    // Clear over the box: from the face looked at, across the box's height (the pad changes by
    // all of it) and width.
    const Ball whole{flat.radius_mm + 2 * ball.pad_half_mm, ball.turn_deg, 2 * ball.pad_half_mm};
    return value < limit + model.fall(s.constraint, v.data(), run.certifier.ball_motion(whole, pose)) ? Decision::unknown
                                                                                                     : Decision::feasible;
  }
  return value < limit + fall ? Decision::unknown : Decision::feasible;
}

CheckReport Checker::dense_check(const Placement& p, double step_mm, Termination& term, Progress* progress) {
  Impl& m = *impl_;
  const Where where = Where::of(p);
  std::vector<CheckReport> per_run;
  const auto changes = m.change_runs(p);
  const std::vector<Run*> of = m.with_changes(changes);
  for (Run* run_ptr : of) {
    Run& run = *run_ptr;
    const std::optional<double> rot =
        run.class1.has_ring() ? std::optional<double>(p.rotation_deg * kDeg) : std::optional<double>(0.0);
    auto extra = [&](const PathPose& pose) { return run.class1.exact(pose, rot, run.shapes(), nullptr); };
    std::vector<Minimum> mins = run.certifier.dense(where, step_mm, term, run.eval_fn(), m.counts, progress, extra);
    const Minimum c1 = mins.back();
    mins.pop_back();
    Finding f1;
    f1.clearance_mm = c1.value;
    f1.pose = c1.pose;
    f1.t = c1.t;
    if (c1.pose >= 0 && std::isfinite(c1.value)) {
      std::string who;
      run.class1.exact(run.tree.at(c1.pose, c1.t), rot, run.shapes(), &who);
      f1.what = who + " / workpiece";
    } else {
      f1.what = "every part at least the safe distance away";
    }
    f1.interferes = c1.value < m.scene.safe_distance_mm;
    per_run.push_back(m.assemble_run(run, p, where, mins, m.in_path(run, f1)));
  }
  CheckReport r = m.assemble(where, per_run, of);
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
