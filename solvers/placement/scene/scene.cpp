#include "solvers/placement/scene/scene.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "engine/common/error.h"
#include "engine/config/yaml.h"
#include "engine/programs/mesh.h"
#include "engine/programs/toolpath.h"
#include "models/cutting/machine_config.h"

namespace machplan::placement {

namespace {
Scene read_scene(const Yaml& root, const std::string& path);

// Reads the file `key` names (a mesh, a tool path). Its errors name the scene, the key's line
// and the key before the file's own message, so that a user learns which entry of which scene
// points to the bad file:
//   scene.yaml:12: key 'workpiece.mesh': parts/x.stl: cannot read ...
template <class Read>
auto read_named_file(const Yaml& key, Read&& read) {
  const std::string file = key.resolve_path(key.string());  // a key that is no text fails on its own
  try {
    return read(file);
  } catch (const InputError& e) {
    throw InputError(key.file(), key.line(), fmt::format("key '{}': {}", key.key_path(), e.what()));
  }
}

Peripheral read_peripheral(const Yaml& y) {
  y.reject_unknown_keys({"name", "box", "mesh", "pose"});
  Peripheral p{.name = y.string("name"), .shape = interference::Shape::sphere(1.0), .T_table_peripheral = Eigen::Isometry3d::Identity(), .bounds = {},
               .outline = {}, .is_box = false, .box_half_mm = Eigen::Vector3d::Zero()};
  if (y.has("box") == y.has("mesh")) y.fail("needs exactly one of 'box' or 'mesh'");
  if (const auto box = y.get("box")) {
    box->reject_unknown_keys({"center", "size", "yaw_deg"});
    const Eigen::Vector3d c = box->vec3("center");
    const Eigen::Vector3d s = box->vec3("size");
    if ((s.array() <= 0).any()) box->at("size").fail("must be three positive sizes");
    if ((s.array() > kMaxSceneSizeMm).any()) box->at("size").fail(fmt::format("sizes must not exceed {} mm", kMaxSceneSizeMm));
    if ((c.array().abs() > kMaxScenePositionMm).any())
      box->at("center").fail(fmt::format("must lie within +-{} mm", kMaxScenePositionMm));
    const double yaw = box->number_or("yaw_deg", 0.0, {.min = -360, .max = 360}) * kDeg;
    p.shape = interference::Shape::box(s);
    p.T_table_peripheral.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    p.T_table_peripheral.translation() = c;
    p.is_box = true;
    p.box_half_mm = s / 2;
    for (int k = 0; k < 8; ++k) {
      const Eigen::Vector3d corner(k & 1 ? s.x() / 2 : -s.x() / 2, k & 2 ? s.y() / 2 : -s.y() / 2,
                                   k & 4 ? s.z() / 2 : -s.z() / 2);
      p.bounds.extend(p.T_table_peripheral * corner);
    }
    for (int k : {0, 1, 3, 2}) {
      const Eigen::Vector3d corner(k & 1 ? s.x() / 2 : -s.x() / 2, k & 2 ? s.y() / 2 : -s.y() / 2, 0);
      p.outline.push_back((p.T_table_peripheral * corner).head<2>());
    }
  } else {
    const Mesh mesh = read_named_file(y.at("mesh"), [](const std::string& f) { return read_stl(f); });
    if (const auto pose = y.get("pose")) {
      pose->reject_unknown_keys({"xyz", "yaw_deg"});
      p.T_table_peripheral.translation() = pose->vec3("xyz");
      if ((p.T_table_peripheral.translation().array().abs() > kMaxScenePositionMm).any())
        pose->at("xyz").fail(fmt::format("must lie within +-{} mm", kMaxScenePositionMm));
      p.T_table_peripheral.linear() =
          Eigen::AngleAxisd(pose->number_or("yaw_deg", 0.0, {.min = -360, .max = 360}) * kDeg, Eigen::Vector3d::UnitZ())
              .toRotationMatrix();
    }
    p.shape = interference::Shape::mesh(mesh.vertices, mesh.triangles);
    for (const auto& v : mesh.vertices) p.bounds.extend(p.T_table_peripheral * v);
    const auto& b = p.bounds;
    p.outline = {{b.min().x(), b.min().y()}, {b.max().x(), b.min().y()}, {b.max().x(), b.max().y()},
                 {b.min().x(), b.max().y()}};
  }
  return p;
}

// The machine file: a path relative to the scene, or the name of a bundled machine (no '/' and
// no '.') found as NAME.yaml in the machine folders (`machplan machines` lists them).
std::string machine_file(const Yaml& root) {
  const Yaml key = root.at("machine");
  const std::string value = key.string();
  if (value.find('/') != std::string::npos || value.find('.') != std::string::npos || value.empty())
    return root.resolve_path(value);
  std::error_code ec;
  for (const auto& f : cutting::machine_folders()) {
    const std::filesystem::path candidate = std::filesystem::path(f.path) / (value + ".yaml");
    if (std::filesystem::is_regular_file(candidate, ec)) return candidate.string();
  }
  key.fail(fmt::format("no machine named '{}' in the machine folders (`machplan machines` lists them); a file needs "
                       "its .yaml",
                       value.substr(0, 60)));
}

Tooling read_tooling(const Yaml& t) {
  t.reject_unknown_keys({"tool_diameter_mm", "corner_radius_mm", "stick_out_mm", "flute_length_mm", "chuck_diameter_mm",
                         "chuck_length_mm"});
  const NumberRule size{.min = 0, .max = kMaxSceneSizeMm, .min_exclusive = true};
  Tooling tooling;
  tooling.tool_diameter_mm = t.number("tool_diameter_mm", size);
  tooling.corner_radius_mm = t.number_or("corner_radius_mm", tooling.tool_diameter_mm / 2, {.min = 0, .max = kMaxSceneSizeMm});
  if (tooling.corner_radius_mm > tooling.tool_diameter_mm / 2 + 1e-9)
    t.at("corner_radius_mm").fail("must not exceed half the tool diameter");
  tooling.stick_out_mm = t.number("stick_out_mm", size);
  tooling.flute_length_mm = t.number_or("flute_length_mm", tooling.stick_out_mm / 2, size);
  tooling.chuck_diameter_mm = t.number("chuck_diameter_mm", size);
  tooling.chuck_length_mm = t.number("chuck_length_mm", size);
  if (tooling.flute_length_mm > tooling.stick_out_mm) t.at("flute_length_mm").fail("must not exceed stick_out_mm");
  return tooling;
}

// A tool of a CL file that changes tools: what the file says of it, then the scene's holder for
// what it does not say, then the scene's `tools` entry for it (see scene.h).
Tooling tool_of(const ToolPath::Tool& t, const std::optional<Yaml>& holder, const std::optional<Yaml>& entry,
                const Yaml& root, const std::string& where) {
  const NumberRule size{.min = 0, .max = kMaxSceneSizeMm, .min_exclusive = true};
  std::optional<double> d, r, stick, flute, chuck_d, chuck_l;
  if (t.cutter) {
    d = t.cutter->diameter_mm;
    r = t.cutter->corner_radius_mm;
    if (t.cutter->length_mm > 0) flute = t.cutter->length_mm;
  }
  if (t.flute_mm > 0) flute = t.flute_mm;
  if (t.extension_mm > 0) stick = t.extension_mm;
  if (holder) {
    if (holder->has("diameter_mm")) chuck_d = holder->number("diameter_mm", size);
    if (holder->has("length_mm")) chuck_l = holder->number("length_mm", size);
    // A tool table's length runs from the tip to the spindle: the holder's length is in it.
    if (!stick && t.gauge_mm > 0 && chuck_l) {
      if (t.gauge_mm <= *chuck_l)
        throw InputError(root.file(), root.at("tool_table").line(),
                         fmt::format("{}: its length {:g} mm ({}) does not reach past the {:g} mm holder", t.name(),
                                     t.gauge_mm, t.table, *chuck_l));
      stick = t.gauge_mm - *chuck_l;
    }
    if (!stick && holder->has("stick_out_mm")) stick = holder->number("stick_out_mm", size);
  }
  if (entry) {
    entry->reject_unknown_keys({"tool_diameter_mm", "corner_radius_mm", "stick_out_mm", "flute_length_mm",
                                "chuck_diameter_mm", "chuck_length_mm"});
    auto take = [&](const char* key, std::optional<double>& v, const NumberRule& rule) {
      if (entry->has(key)) v = entry->number(key, rule);
    };
    take("tool_diameter_mm", d, size);
    take("corner_radius_mm", r, {.min = 0, .max = kMaxSceneSizeMm});
    take("stick_out_mm", stick, size);
    take("flute_length_mm", flute, size);
    take("chuck_diameter_mm", chuck_d, size);
    take("chuck_length_mm", chuck_l, size);
  }
  const std::string n = t.number >= 0 ? std::to_string(t.number) : "N";
  auto missing = [&](bool ok, const char* what, const char* holder_key, const char* tool_key) {
    if (ok) return;
    throw InputError(root.file(), root.at("toolpath").line(),
                     fmt::format("{} ({}) has no {}: give the scene's holder: {{{}: ...}} for every tool, or tools: "
                                 "{{{}: {{{}: ...}}}}",
                                 t.name(), where, what, holder_key, n, tool_key));
  };
  if (!d)
    throw InputError(root.file(), root.at("toolpath").line(),
                     fmt::format("{} ({}) is loaded with nothing to say what it is (no CUTTER, no tool table entry): describe it in the scene, "
                                 "tools: {{{}: {{tool_diameter_mm: ..., stick_out_mm: ...}}}}",
                                 t.name(), where, n));
  missing(stick.has_value(), "length out of the holder", "stick_out_mm", "stick_out_mm");
  missing(chuck_d.has_value(), "holder diameter", "diameter_mm", "chuck_diameter_mm");
  missing(chuck_l.has_value(), "holder length", "length_mm", "chuck_length_mm");
  Tooling tooling;
  tooling.tool_diameter_mm = *d;
  tooling.corner_radius_mm = r.value_or(*d / 2);
  tooling.stick_out_mm = *stick;
  tooling.flute_length_mm = flute.value_or(*stick / 2);
  tooling.chuck_diameter_mm = *chuck_d;
  tooling.chuck_length_mm = *chuck_l;
  auto refuse = [&](const std::string& why) {
    throw InputError(root.file(), root.at("toolpath").line(), fmt::format("{} ({}): {}", t.name(), where, why));
  };
  if (tooling.corner_radius_mm > tooling.tool_diameter_mm / 2 + 1e-9)
    refuse(fmt::format("corner radius {:g} mm exceeds half its diameter {:g} mm", tooling.corner_radius_mm,
                       tooling.tool_diameter_mm));
  if (tooling.flute_length_mm > tooling.stick_out_mm)
    refuse(fmt::format("flutes {:g} mm long but only {:g} mm out of the holder: give tools: {{{}: {{flute_length_mm: "
                       "...}}}} or its stick_out_mm",
                       tooling.flute_length_mm, tooling.stick_out_mm, n));
  return tooling;
}

// The tools of the job and the runs of poses each makes (see scene.h); a pose's ToolPose::tool
// is its index into tp.tools (-1: before any tool).
void read_tools(const Yaml& root, const ToolPath& tp, Scene& s) {
  std::vector<int> used;  // tp.tools indices that move, in order of first use
  for (const ToolPose& p : tp.poses)
    if (p.tool >= 0 && std::find(used.begin(), used.end(), p.tool) == used.end()) used.push_back(p.tool);
  std::string names;  // "T6, T16, T2"
  for (int k : used) names += (names.empty() ? "" : ", ") + tp.tools[k].name();
  std::vector<int> scene_tool(tp.tools.size(), -1);
  const std::string file = std::filesystem::path(tp.source).filename().string();
  if (const auto t = root.get("tooling")) {
    if (used.size() > 1)
      t->fail(fmt::format("is one tool for every move, but the tool path changes tools ({}): describe them with "
                          "holder: and tools: instead",
                          names));
    for (const char* key : {"holder", "tools"})
      if (root.has(key)) root.at(key).fail("goes with a tool path that changes tools, not with tooling:");
    s.tools.push_back({-1, "the tooling", root.file(), t->line(), read_tooling(*t), nullptr});
    std::fill(scene_tool.begin(), scene_tool.end(), 0);
  } else {
    if (used.empty())
      root.fail(fmt::format("needs tooling: {} names no tool (no CUTTER, no LOAD/TOOL)", file));
    const auto holder = root.get("holder");
    if (holder) holder->reject_unknown_keys({"diameter_mm", "length_mm", "stick_out_mm"});
    const auto tools = root.get("tools");
    if (tools)
      for (const std::string& key : tools->keys()) {
        bool loaded = false;
        for (int k : used) loaded = loaded || std::to_string(tp.tools[k].number) == key;
        if (!loaded)
          tools->at(key).fail(fmt::format("{} makes no move with a tool numbered '{}' (its tools: {})", file,
                                          key.substr(0, 20), names));
      }
    for (int k : used) {
      const ToolPath::Tool& t = tp.tools[k];
      const std::string where = fmt::format("{}:{}", file, t.line);
      std::optional<Yaml> entry;
      if (tools && t.number >= 0) entry = tools->get(std::to_string(t.number));
      scene_tool[k] = static_cast<int>(s.tools.size());
      s.tools.push_back({t.number, t.name(), tp.source, t.line, tool_of(t, holder, entry, root, where), nullptr});
    }
  }
  // Runs: a pose before any tool is made with the first one.
  for (std::size_t i = 0; i < tp.poses.size(); ++i) {
    const int k = tp.poses[i].tool >= 0 ? scene_tool[tp.poses[i].tool] : 0;
    if (s.runs.empty() || s.runs.back().tool != k) s.runs.push_back({k, i, i});
    s.runs.back().end = i + 1;
  }
  s.tooling = s.tools[s.runs.front().tool].tooling;
}

// The machine file's tool change position (scene.h ToolChange), when the job changes tools.
// With the tool vertical at that position the machine stands as it would whatever the
// workpiece's placement, so each tool is tried there once: a position beyond the travel or into
// a peripheral is refused here rather than found at every placement.
void read_tool_change(const Yaml& machine, Scene& s) {
  const auto tc = machine.get("tool_change");
  if (!tc) return;
  tc->reject_unknown_keys({"nose_mm"});
  ToolChange c{tc->vec3("nose_mm"), tc->file(), tc->line()};
  if ((c.nose_mm.array().abs() > kMaxScenePositionMm).any())
    tc->at("nose_mm").fail(fmt::format("must lie within +-{} mm", kMaxScenePositionMm));
  s.tool_change = c;
  if (s.runs.size() < 2) return;
  for (const SceneTool& t : s.tools) {
    const double gauge = t.tooling.stick_out_mm + t.tooling.chuck_length_mm;
    std::vector<PathPose> pose{{c.nose_mm - gauge * Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ()}};
    if (const auto refused = t.model->prepare(pose))
      tc->at("nose_mm").fail(fmt::format("the machine cannot hold {} vertical there: {}", t.name, refused->second));
    const MachineModel& m = *t.model;
    std::vector<double> v(m.stride());
    m.evaluator()->evaluate(pose[0], Where::of(Placement{}), m.all_mask(), v.data());
    for (int k = 0; k < m.count(); ++k) {
      const Constraint& con = m.constraints()[k];
      if ((con.kind == Kind::self || con.kind == Kind::machine_peripheral) && v[k] < con.limit)
        tc->at("nose_mm").fail(fmt::format("puts {} ({:g} mm from its tip to the spindle nose) where '{}' is broken: {:.2f} "
                                           "against a limit of {:g}",
                                           t.name, gauge, con.name, v[k], con.limit));
    }
  }
}

// The workpiece solid, moved into its own frame (origin at the centre of the bottom face of
// its bounds, or origin_in_cam_mm); records the move in the scene.
void read_workpiece(const Yaml& root, Scene& s) {
  const Yaml w = root.at("workpiece");
  w.reject_unknown_keys({"mesh", "box", "origin_in_cam_mm", "spoilboard_mm"});
  if (w.has("mesh") == w.has("box")) w.fail("needs exactly one of 'mesh' or 'box'");
  Mesh mesh;
  if (const auto m = w.get("mesh")) {
    const std::string file = root.resolve_path(m->string());
    s.workpiece_file = file;
    MeshReport report;
    mesh = read_named_file(*m, [&report](const std::string& f) { return read_stl(f, &report); });
    if (!report.closed)
      m->fail(fmt::format("names {}, which is not a closed solid ({} boundary and {} non-manifold edges)", file,
                          report.boundary_edges, report.non_manifold_edges));
  } else {
    const Yaml box = w.at("box");
    box.reject_unknown_keys({"size"});
    const Eigen::Vector3d size = box.vec3("size");
    if ((size.array() <= 0).any()) box.at("size").fail("must be three positive sizes");
    if ((size.array() > kMaxSceneSizeMm).any()) box.at("size").fail(fmt::format("sizes must not exceed {} mm", kMaxSceneSizeMm));
    mesh = make_box_mesh({-size.x() / 2, -size.y() / 2, 0}, {size.x() / 2, size.y() / 2, size.z()});
  }
  Eigen::AlignedBox3d cam;
  for (const auto& v : mesh.vertices) cam.extend(v);
  if (const auto o = w.get("origin_in_cam_mm")) {
    s.origin_in_cam_mm = o->vec3();
    s.origin_from_mesh = false;
    if ((s.origin_in_cam_mm.array().abs() > kMaxScenePositionMm).any())
      o->fail(fmt::format("must lie within +-{} mm", kMaxScenePositionMm));
  } else {
    s.origin_in_cam_mm = {cam.center().x(), cam.center().y(), cam.min().z()};
  }
  for (const auto& v : mesh.vertices) s.workpiece_vertices.push_back(v - s.origin_in_cam_mm);
  s.workpiece_triangles = mesh.triangles;
  for (const auto& v : s.workpiece_vertices) s.workpiece_bounds.extend(v);
  if (s.workpiece_bounds.min().z() < -1e-6)
    w.at("origin_in_cam_mm")
        .fail(fmt::format("puts the origin {:.3f} mm above the solid's lowest point; the workpiece frame has its origin on "
                          "the bottom face, so nothing may lie below it",
                          -s.workpiece_bounds.min().z()));
  s.spoilboard_mm = w.number_or("spoilboard_mm", 0.0, {.min = 0, .max = kMaxSceneSizeMm});
}

ToolPath read_toolpath(const Yaml& root, Scene& s) {
  s.toolpath_file = root.resolve_path(root.string("toolpath"));
  ToolPath tp = read_named_file(root.at("toolpath"), [](const std::string& f) { return read_toolpath_file(f); });
  if (tp.poses.empty()) root.at("toolpath").fail("names a tool path with no poses");
  if (root.has("tool_table")) {
    const std::string file = root.resolve_path(root.string("tool_table"));
    const auto table = read_named_file(root.at("tool_table"), [](const std::string& f) { return read_tool_table_file(f); });
    apply_tool_table(tp, table, std::filesystem::path(file).filename().string());
  }
  // The feed of every move the file gives none for (a CSV without a feed column).
  const double feed = root.number_or("feed_mm_per_min", 0.0, {.min = 0, .max = 1e7});
  s.tips_mm.reserve(tp.poses.size());
  s.axes.reserve(tp.poses.size());
  for (std::size_t i = 0; i < tp.poses.size(); ++i) {
    const ToolPose& p = tp.poses[i];
    s.tips_mm.push_back(p.tip_mm - s.origin_in_cam_mm);
    s.axes.push_back(p.axis);
    s.lines.push_back(p.line);
    s.feeds_mm_per_min.push_back(p.rapid ? 0.0 : p.feed_mm_per_min > 0.0 ? p.feed_mm_per_min : feed);
    const double below = -s.tips_mm.back().z();
    if (below > 1e-6) {
      ++s.below_bottom.poses;
      if (below > s.below_bottom.deepest_mm)
        s.below_bottom = {s.below_bottom.poses, below, static_cast<long>(i), p.line};
    }
  }
  s.warnings = tp.warnings;
  return tp;
}

void read_search(const Yaml& root, Scene& s) {
  const auto se = root.get("search");
  if (!se) return;
  se->reject_unknown_keys({"pad_max_mm", "pad_min_mm", "paper_step_mm", "paper_pad_step_mm", "reversal_deg", "resolution_mm",
                           "rotation_step_deg", "paper_max_steps", "max_pose_queries"});
  const NumberRule pos{.min = 0, .min_exclusive = true};
  s.search.pad_max_mm = se->number_or("pad_max_mm", s.search.pad_max_mm, {.min = 0, .max = kMaxSceneSizeMm});
  s.search.pad_min_mm = se->number_or("pad_min_mm", s.search.pad_min_mm, {.min = 0, .max = kMaxSceneSizeMm});
  if (s.search.pad_min_mm > s.search.pad_max_mm) se->at("pad_min_mm").fail("must not exceed pad_max_mm");
  s.search.paper_step_mm = se->number_or("paper_step_mm", s.search.paper_step_mm, pos);
  s.search.paper_pad_step_mm = se->number_or("paper_pad_step_mm", s.search.paper_pad_step_mm, pos);
  s.search.reversal_deg = se->number_or("reversal_deg", s.search.reversal_deg, {.min = 0, .max = 180});
  s.search.resolution_mm = se->number_or("resolution_mm", s.search.resolution_mm,
                                         {.min = kMinResolutionMm, .max = kMaxResolutionMm});
  s.search.rotation_step_deg = se->number_or("rotation_step_deg", s.search.rotation_step_deg, {.min = 0.01, .max = 90});
  if (se->has("paper_max_steps")) s.search.paper_max_steps = se->at("paper_max_steps").integer(1, 1000000);
  if (se->has("max_pose_queries")) s.search.max_pose_queries = se->at("max_pose_queries").integer(1, 1'000'000'000);
}
}  // namespace

Scene load_scene(const std::string& path) { return read_scene(Yaml::load_file(path), path); }

Scene load_scene_text(const std::string& text, const std::string& path) {
  return read_scene(Yaml::load_string(text, path), path);
}

namespace {
Scene read_scene(const Yaml& root, const std::string& path) {
  root.reject_unknown_keys({"machine", "safe_distance_mm", "tooling", "holder", "tools", "workpiece", "toolpath",
                            "tool_table", "feed_mm_per_min", "peripherals", "search", "reconstructed"});
  Scene s;
  s.source = path;
  s.machine.source = machine_file(root);
  s.safe_distance_mm = root.number_or("safe_distance_mm", 5.0, {.min = 0, .max = 1000});
  read_workpiece(root, s);
  read_tools(root, read_toolpath(root, s), s);
  if (const auto per = root.get("peripherals")) {
    for (const Yaml& item : per->items()) s.peripherals.push_back(read_peripheral(item));
    if (s.peripherals.size() > kMaxPeripherals)
      per->fail(fmt::format("{} peripherals; at most {} are supported", s.peripherals.size(), kMaxPeripherals));
  }
  read_search(root, s);
  if (s.spoilboard_mm > s.search.pad_max_mm)
    root.at("workpiece").at("spoilboard_mm").fail("is thicker than the highest pad (search.pad_max_mm)");
  // The machine file, read once for every tool's model and its tool change position.
  std::optional<Yaml> machine;
  try {
    machine = Yaml::load_file(s.machine.source);
    for (SceneTool& tool : s.tools) tool.model = make_machine_model(s, *machine, tool.tooling, {tool.name, tool.file, tool.line});
  } catch (const InputError& e) {
    // The machine file's own errors (missing, unreadable, malformed) under the scene's key.
    if (e.where() != s.machine.source) throw;
    const Yaml key = root.at("machine");
    throw InputError(key.file(), key.line(), fmt::format("key '{}': {}", key.key_path(), e.what()));
  }
  s.model = s.tools[s.runs.front().tool].model;
  read_tool_change(*machine, s);
  s.machine.kind = s.model->kind();
  const TableShape table = s.model->table();
  s.machine.table_size_mm = 2 * table.half_mm;
  s.machine.name = s.model->name();
  // The path as the machine runs it (the rotary angles depend on the tool axis alone): a pose it
  // cannot take is refused at its line.
  std::vector<PathPose> poses(s.tips_mm.size());
  for (std::size_t i = 0; i < poses.size(); ++i) poses[i] = {s.tips_mm[i], s.axes[i]};
  if (const auto refused = s.model->prepare(poses)) throw InputError(s.toolpath_file, s.lines[refused->first], refused->second);
  return s;
}
}  // namespace

}  // namespace machplan::placement
