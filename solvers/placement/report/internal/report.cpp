#include "solvers/placement/report/internal/report.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace machplan::placement {

namespace {

std::string clearance_text(double v) { return std::isfinite(v) ? fmt::format("{:8.2f} mm", v) : "   >= safe"; }

std::string where_text(const Finding& f) {
  if (f.what.empty() && !std::isfinite(f.clearance_mm)) return "nothing comes within the safe distance";
  std::string where = f.what;
  if (f.pose >= 0) {
    where += fmt::format(" (tool-path index {}{}", f.pose, f.t > 0 ? fmt::format(" +{:.2f}", f.t) : "");
    if (f.line > 0) where += fmt::format(", line {}", f.line);
    where += ")";
  }
  return where;
}

// What the scene did to the CAM file's coordinates, and the path below the bottom face.
std::string frame_lines(const Scene& s) {
  std::string out;
  const Eigen::Vector3d& o = s.origin_in_cam_mm;
  if (!s.origin_from_mesh || o.norm() > 1e-9)
    out += fmt::format("workpiece frame: origin at CAM ({:.3f}, {:.3f}, {:.3f}) mm ({}); mesh and tool path moved by "
                       "({:.3f}, {:.3f}, {:.3f}) mm\n",
                       o.x(), o.y(), o.z(), s.origin_from_mesh ? "the centre of the mesh's bottom face" : "origin_in_cam_mm",
                       -o.x(), -o.y(), -o.z());
  if (s.below_bottom.poses > 0)
    out += fmt::format("tool tips below the bottom face: {} poses, deepest {:.3f} mm below (tool-path index {}, line {}); "
                       "spoilboard {:.1f} mm\n",
                       s.below_bottom.poses, s.below_bottom.deepest_mm, s.below_bottom.deepest_pose, s.below_bottom.deepest_line,
                       s.spoilboard_mm);
  for (const std::string& w : s.warnings) out += fmt::format("WARNING: {}\n", w);
  if (s.tools.size() > 1 || s.tools.front().number >= 0) {
    out += "tools:";
    for (const SceneTool& t : s.tools) {
      const Tooling& g = t.tooling;
      out += fmt::format(" {} ({:g} mm, flutes {:g} mm, {:g} mm out of a {:g} x {:g} mm holder){}", t.name,
                         g.tool_diameter_mm, g.flute_length_mm, g.stick_out_mm, g.chuck_diameter_mm, g.chuck_length_mm,
                         &t == &s.tools.back() ? "" : ";");
    }
    out += "\n";
  }
  for (std::size_t k = 1; k < s.runs.size(); ++k)
    out += fmt::format("tool change to {} before tool-path index {} (line {})\n", s.tools[s.runs[k].tool].name,
                       s.runs[k].first, s.lines[s.runs[k].first]);
  return out;
}

// A rotary axis's travel: in turns once it turns more than once ("C 33.2 turns"), else degrees.
std::string rotary_travel_text(double deg) {
  return deg > 360.0 ? fmt::format("{:.1f} turns", deg / 360.0) : fmt::format("{:.1f} deg", deg);
}

std::string travel_lines(const PlacementResult& r) {
  if (!r.travel) return {};
  const AxisTravel& t = *r.travel;
  std::string axes;
  for (std::size_t k = 0; k < t.axes.size(); ++k)
    axes += fmt::format("{}{} {}", k ? ", " : "", t.axes[k],
                        static_cast<int>(k) < t.linear_axes ? fmt::format("{:.1f} mm", t.travel[k])
                                                            : rotary_travel_text(t.travel[k]));
  std::string out = fmt::format("axis travel: {}\n", axes);
  const bool rotary = t.linear_axes < static_cast<int>(t.axes.size());
  if (r.centre_travel) {
    const AxisTravel& c = *r.centre_travel;
    out += fmt::format("{} travel {:.1f} mm against {:.1f} mm at the table centre ({:.1f} % less)\n",
                       rotary ? "linear" : "slider", t.linear_mm, c.linear_mm, 100.0 * (1.0 - t.linear_mm / c.linear_mm));
    // The time is each step's programmed feed unless a linear axis would need more than its
    // speed limit; only then can the workpiece's place change it. A comparison of two equal
    // feed-set times would only look like a result.
    if (t.planned)
      out += fmt::format("machining time by the feed planner: {:.1f} s against {:.1f} s at the table centre ({:.1f} % "
                         "less); at the speed limits alone {:.1f} s against {:.1f} s\n",
                         t.time_s, c.time_s, 100.0 * (1.0 - t.time_s / c.time_s), t.velocity_only_time_s,
                         c.velocity_only_time_s);
    else if (std::abs(t.time_s - c.time_s) >= 0.05)
      out += fmt::format("machining time at the programmed feeds and the axes' speed limits: {:.1f} s against {:.1f} s "
                         "at the table centre ({:.1f} % less)\n",
                         t.time_s, c.time_s, 100.0 * (1.0 - t.time_s / c.time_s));
    else
      out += fmt::format("machining time {:.1f} s, set by the programmed feeds here as at the table centre (no linear "
                         "axis reaches its speed limit)\n",
                         t.time_s);
  }
  if (!rotary) return out;
  out += t.flips == 0 ? std::string("rotary flips: none\n")
                      : fmt::format("rotary flips: {} ({} forced by the axis limits), first at tool-path index {}\n", t.flips,
                                    t.forced_flips, t.flip_poses.empty() ? -1 : t.flip_poses.front());
  return out;
}

}  // namespace

const char* height_name(const Scene& scene) { return scene.machine.kind == "hexapod" ? "pad" : "fixture height"; }

std::string budget_message(const Scene& scene) {
  return fmt::format(
      "{}: the interference check stopped at its limit of {} exact pose queries (search.max_pose_queries in the scene) "
      "without an answer; with a safe distance of {} mm little of the path can be certified in bulk. Raise the limit in "
      "the scene to let it run longer.",
      scene.source, scene.search.max_pose_queries, scene.safe_distance_mm);
}

std::string kinds_table(const Scene& scene, const CheckReport& r) {
  std::string out = fmt::format("  {:<22} {:<12} {:<11} {}\n", "kind", "verdict", "clearance", "where");
  for (int k = 0; k < kKindCount; ++k) {
    const Finding& f = r.kinds[k];
    out += fmt::format("  {:<22} {:<12} {}  {}\n", kind_name(static_cast<Kind>(k)), f.interferes ? "INTERFERES" : "free",
                       clearance_text(f.clearance_mm), where_text(f));
  }
  const bool hexapod = scene.machine.kind == "hexapod";
  out += fmt::format("  {} margin {:.1f} mm, {} margin {:.1f} deg, safe distance {:.1f} mm\n",
                     hexapod ? "slider stroke" : "linear axis travel", r.stroke_margin_mm,
                     hexapod ? "joint cone" : "rotary axis", r.joint_margin_deg, scene.safe_distance_mm);
  if (!r.on_table) out += "  the workpiece overhangs the table\n";
  if (r.tools.size() > 1)
    for (const ToolClearance& t : r.tools)
      out += fmt::format("  {:<8} {:>6} poses, tightest {} ({}): {}\n", t.tool, t.poses, clearance_text(t.tightest.clearance_mm),
                         kind_name(t.kind), where_text(t.tightest));
  return out;
}

void write_check_summary(const Scene& scene, CheckResult& result) {
  Summary& s = result.summary;
  const CheckReport& r = result.report;
  const Placement& p = r.placement;
  if (!s.done()) {
    s.brief = fmt::format("check {}: {}", to_string(s.status), s.message);
    s.full = fmt::format("machplan check {}: {} before a verdict: {}\n", scene.source, to_string(s.status), s.message);
    return;
  }
  const bool free = r.free() && r.on_table;
  s.brief = fmt::format("{} at x {:.2f}, y {:.2f}, pad {:.1f} mm, rotation {:g} deg", free ? "FREE" : "INTERFERENCE", p.x_mm,
                        p.y_mm, p.pad_mm, p.rotation_deg);
  s.full = fmt::format("machplan check {} at x {:.2f}, y {:.2f}, pad {:.1f} mm{}: {}{}\n", scene.source, p.x_mm, p.y_mm,
                       p.pad_mm, p.rotation_deg != 0 ? fmt::format(", rotation {:g} deg", p.rotation_deg) : "",
                       free ? "FREE" : "INTERFERENCE", result.dense ? " (dense re-check)" : "");
  s.full += frame_lines(scene);
  s.full += kinds_table(scene, r);
}

void write_place_summary(const Scene& scene, const PlacementOptions& o, bool rotations_reduced, PlacementResult& r) {
  Summary& s = r.summary;
  const bool optimal = o.strategy == PlacementOptions::Strategy::optimal;
  const std::string head = fmt::format(
      "machplan place {} (machine {}, strategy {}, objective {}, {} tool poses, safe distance {:.1f} mm, {} thread{})\n",
      scene.source, scene.machine.name, optimal ? "optimal" : "paper", to_string(r.objective), scene.tips_mm.size(),
      scene.safe_distance_mm, r.threads, r.threads == 1 ? "" : "s");
  if (r.ended_early()) {
    s.brief = fmt::format("place {}: {}", to_string(s.status), s.message);
    s.full = head + fmt::format("placement search ended ({}) before an answer: {}\ntime: {:.3f} s\n", to_string(s.status),
                                s.message, r.seconds);
    return;
  }
  const Placement& p = r.placement;
  std::string full = head + frame_lines(scene);
  if (s.done()) {
    s.brief = fmt::format("x {:.2f} mm, y {:.2f} mm, {} {:.1f} mm, rotation {:g} deg{}", p.x_mm, p.y_mm,
                          height_name(scene), p.pad_mm, p.rotation_deg,
                          r.verified ? ", certified free" : "");
    full += fmt::format("placement: x {:.2f} mm, y {:.2f} mm, {} {:.1f} mm, rotation {:g} deg  ({})\n", p.x_mm, p.y_mm,
                        height_name(scene), p.pad_mm, p.rotation_deg, s.message);
    if (r.rotations > 1)
      full += fmt::format("rotations: {} searched; the answer is certified free {}\n", r.rotations,
                          r.rotation_tolerance_deg > 0
                              ? fmt::format("for every rotation from {:.3f} to {:.3f} deg", p.rotation_deg - r.rotation_tolerance_deg,
                                            p.rotation_deg + r.rotation_tolerance_deg)
                              : fmt::format("at {:g} deg exactly ({})", p.rotation_deg,
                                            scene.tool_change && scene.runs.size() > 1
                                                ? "the tool changes' moves are certified at single placements"
                                                : "no turn around it could be proven free"));
    if (rotations_reduced)
      full += "rotations: on this machine a turn of the rotary table is the same setup as a position, so one rotation "
              "was searched\n";
    const WorkOffset& w = r.work_offset;
    full += fmt::format("work offset (G54, the CAM zero from {}): X {:.3f} Y {:.3f} Z {:.3f}, rotation {:.3f} deg ({})\n",
                        w.frame, w.xyz_mm.x(), w.xyz_mm.y(), w.xyz_mm.z(), w.rotation_deg, w.rotation_axis);
    full += fmt::format("certified free over the whole path: {}\n", r.verified ? "yes" : "NO");
  } else {
    s.message = "cannot be machined on this machine: " + s.message;
    s.brief = s.message;
    full += s.message + "\n";
  }
  if (std::any_of(r.report.kinds.begin(), r.report.kinds.end(), [](const Finding& f) { return f.pose >= 0; }))
    full += kinds_table(scene, r.report);
  full += travel_lines(r);
  full += fmt::format("checks: {} placements examined{}, {} exact pose queries, {} interpolated poses, {} tree nodes ({} "
                      "proven by bound)\n",
                      r.placements_examined, optimal ? fmt::format(" ({} certified over the whole path)", r.certifications) : "",
                      r.counts.exact_queries, r.counts.interpolated_poses, r.counts.stretches, r.counts.proven_by_bound);
  full += fmt::format("time: {:.3f} s\n", r.seconds);
  s.full = std::move(full);
}

const char* kind_name(Kind k) {
  switch (k) {
    case Kind::self: return "self";
    case Kind::workpiece_class1: return "workpiece_class1";
    case Kind::workpiece_class2: return "workpiece_class2";
    case Kind::machine_peripheral: return "machine_peripheral";
    case Kind::workpiece_peripheral: return "workpiece_peripheral";
    case Kind::tool_support: return "tool_support";
  }
  return "?";
}

bool CheckReport::free() const {
  for (const Finding& f : kinds)
    if (f.interferes) return false;
  return on_table;
}

}  // namespace machplan::placement
