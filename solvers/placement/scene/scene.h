// A placement problem as the process planner writes it: the machine, the tooling, the
// workpiece and its tool path as the CAM system exported them, the peripherals on the table
// and the clearance to keep. Read from YAML; every path inside is relative to the scene file.
//
//   machine: machine.yaml            # a file, or the name of a bundled machine (trunnion_ac)
//   safe_distance_mm: 5              # objects are grown by this much (the paper's safe distance)
//   tooling: {tool_diameter_mm: 10, corner_radius_mm: 5, stick_out_mm: 50, flute_length_mm: 20,
//             chuck_diameter_mm: 60, chuck_length_mm: 45}   # one tool for every move, or:
//   holder: {diameter_mm: 50, length_mm: 60, stick_out_mm: 40}  # every tool of the CL file
//   tools: {16: {stick_out_mm: 170, chuck_diameter_mm: 63}}    # by number: tooling keys
//   workpiece: {mesh: part.stl,               # or {box: {size: [dx, dy, dz]}}
//               origin_in_cam_mm: [x, y, z],  # optional, see below
//               spoilboard_mm: 0}             # sacrificial top of the pad the tool may cut into
//   toolpath: part.apt                        # CL (APT), G-code or CSV, in the CAM file's coordinates
//   tool_table: tool.tbl                      # LinuxCNC tool table for a G-code job's tools
//   feed_mm_per_min: 3000                     # the feed of moves the file gives none for (CSV)
//   peripherals:
//     - {name: tool magazine, box: {center: [x, y, z], size: [dx, dy, dz], yaw_deg: 45}}
//     - {name: fixture, mesh: fixture.stl, pose: {xyz: [x, y, z], yaw_deg: 0}}
//   search: {pad_max_mm: 300, pad_min_mm: 0, paper_step_mm: 10, paper_pad_step_mm: 10,
//            resolution_mm: 1, rotation_step_deg: 1, max_pose_queries: 3000000}
//
// The workpiece frame. The mesh and the tool path come in the CAM file's coordinates, whose
// zero is wherever the CAM setup put it (the top of the stock, a corner). The workpiece frame
// has its origin at the centre of the mesh's bounding box's bottom face, z up; both the mesh
// and the tool path are moved into it together, and `origin_in_cam_mm` (the CAM coordinates of
// the point that becomes the origin) overrides where that is. `origin_in_cam_mm` below records
// what was used, so reports can say by how much the CAM frame moved and give the work offset of
// the CAM zero. Nothing of the solid may lie below the origin's z.
//
// Tools. A CL file that loads tools (LOAD/TOOL) and describes them (CUTTER, CAMWorks' flute
// and extension lengths) is checked move by move with the tool that makes it: each tool gets
// its diameter, corner radius and flute length from its CUTTER, its length out of the holder
// from the file where it says so, and the rest from `holder` (the holder's diameter and length
// out of the spindle, and a stick-out for tools the file gives none). `tools`, keyed by the
// tool's number, overrides any of the tooling keys for one tool. A G-code job names its tools
// by M6; a LinuxCNC tool table (`tool_table`) gives their diameters and lengths (from the tip
// to the spindle: the stick-out is that less the holder's length). A value no source gives, a
// tool the file loads without describing it, a key of `tools` the file never loads, are
// refused with the tool's name and the line that loads it. `tooling` is the one tool of a path
// made with at most one tool (it then overrides the file's CUTTER); with a path that changes
// tools it is refused. Moves before the first LOAD are made with the first tool loaded.
//
// Tool poses whose tip lies below the bottom face (through cuts, drilling) are counted in
// `below_bottom`; the pad or fixture under the part then stands in the tool's way (kind
// tool_support) unless the scene declares a sacrificial spoilboard at least that deep plus the
// safe distance. The pad is never thinner than the spoilboard.
//
// Bounds: safe_distance_mm 0 .. 1000; tooling sizes, box sizes, spoilboard_mm and pad limits
// up to kMaxSceneSizeMm; origin_in_cam_mm, peripheral centres and poses within
// +-kMaxScenePositionMm; yaw_deg within +-360; rotation_step_deg 0.01 .. 90; resolution_mm
// kMinResolutionMm .. kMaxResolutionMm; max_pose_queries 1 .. 1e9.
//
// A placement (x, y, pad, rotation) puts the workpiece origin at (x, y, pad) in the machine's
// table frame, turned by rotation about z (machines/finding.h).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "engine/interference/collision.h"
#include "models/common/tooling.h"
#include "solvers/placement/machines/machine_model.h"

namespace machplan::placement {

struct Peripheral {
  std::string name;
  interference::Shape shape;
  Eigen::Isometry3d T_table_peripheral = Eigen::Isometry3d::Identity();
  Eigen::AlignedBox3d bounds;           // table frame
  std::vector<Eigen::Vector2d> outline;  // xy outline (box corners) for plots
  bool is_box = false;
  Eigen::Vector3d box_half_mm = Eigen::Vector3d::Zero();
};

struct SearchSettings {
  double pad_max_mm = 300.0;        // highest pad (fixture) considered
  double pad_min_mm = 0.0;          // lowest; never below the spoilboard
  double paper_step_mm = 10.0;      // the paper's evasion step
  double paper_pad_step_mm = 10.0;  // the paper's pad increment
  double reversal_deg = 150.0;      // evasion directions further apart than this raise the pad
  // Grid of the optimal search (x, y and pad), kMinResolutionMm .. kMaxResolutionMm. The
  // search's work grows about as 1 / resolution^2 (the placements it examines near the
  // answer): on the bundled scene 1 mm examines about 2e4 placements, 0.1 mm 8e5 (about ten
  // times the time), 0.02 mm 2.6e7 (minutes). A grid finer than 0.1 mm is finer than a
  // workpiece is set on a machine table, so it is refused rather than searched.
  double resolution_mm = 1.0;
  double rotation_step_deg = 1.0;   // grid of `--rotations any`
  int paper_max_steps = 2000;       // the paper's search gives up after this many moves
  // Work budget of one checker call (one `check`, one decision of the search): exact pose
  // queries. An ordinary check of the bundled scene makes about 3e4; past the budget the call
  // ends with status `budget` naming this key.
  long max_pose_queries = 3'000'000;
};

// The optimal search's grid, mm (SearchSettings::resolution_mm).
inline constexpr double kMinResolutionMm = 0.1;
inline constexpr double kMaxResolutionMm = 100.0;

// Upper bounds on the scene's sizes and positions (mm). No machine tool reaches them; beyond
// them the geometry's squares and sums lose all precision or overflow.
inline constexpr double kMaxSceneSizeMm = 10'000.0;      // tools, peripherals, pads
inline constexpr double kMaxScenePositionMm = 100'000.0;  // peripheral positions
// At most this many peripherals (the checker keeps a bit per constraint in a 64-bit mask).
inline constexpr std::size_t kMaxPeripherals = 14;

struct MachineInfo {
  std::string name;
  std::string source;   // the machine file
  std::string kind;     // "hexapod", "table_tilting"
  Eigen::Vector2d table_size_mm = Eigen::Vector2d::Zero();  // the table's extent (a round table: its diameter)
};

// Tool tips below the workpiece's bottom face.
struct BelowBottom {
  long poses = 0;
  double deepest_mm = 0.0;  // how far below (positive)
  long deepest_pose = -1;
  int deepest_line = 0;
};

// Where the machine changes tools, from the machine file's `tool_change: {nose_mm: [x, y, z]}`:
// the spindle nose (where the holder meets the spindle) in the table frame, the tool vertical
// (on a table-tilting machine, with the rotary axes at zero). A job that changes tools goes
// there and back at each change, and those moves are checked with the rest
// (check/internal/tool_change.h).
struct ToolChange {
  Eigen::Vector3d nose_mm = Eigen::Vector3d::Zero();
  std::string file;  // the machine file ...
  int line = 0;      // ... and the key's line
};

// One tool of the job and the machine model built with it.
struct SceneTool {
  int number = -1;          // the CL file's tool number; -1 when it has none
  std::string name;         // "T16", "the tooling"
  std::string file;         // where it is loaded or described (for messages) ...
  int line = 0;             // ... and the line
  Tooling tooling;
  std::shared_ptr<const MachineModel> model;  // the machine with this tool
};

// Poses [first, end) of the path are made with tools[tool]; each tool change starts a run.
struct ToolRun {
  int tool = 0;
  std::size_t first = 0, end = 0;
};

struct Scene {
  std::string source;
  MachineInfo machine;
  // The machine with the first run's tool: for what does not depend on the tool (the table,
  // the work offset, the placement-only checks).
  std::shared_ptr<const MachineModel> model;
  Tooling tooling;                 // the first run's tool
  std::vector<SceneTool> tools;    // at least one
  std::vector<ToolRun> runs;       // cover every pose, in order
  std::vector<std::string> warnings;  // the tool path's (ToolPath::warnings)
  std::optional<ToolChange> tool_change;  // the machine's, when it names one
  double safe_distance_mm = 5.0;
  std::string toolpath_file;
  std::string workpiece_file;  // the STL, when the workpiece is a mesh; empty for a box
  std::vector<Eigen::Vector3d> tips_mm;  // workpiece frame
  std::vector<Eigen::Vector3d> axes;     // unit
  std::vector<int> lines;                // tool-path file line of each pose
  std::vector<double> feeds_mm_per_min;  // feed in force at each pose; 0 a rapid
  // Workpiece solid in its own frame.
  std::vector<Eigen::Vector3d> workpiece_vertices;
  std::vector<Eigen::Vector3i> workpiece_triangles;
  Eigen::AlignedBox3d workpiece_bounds;
  Eigen::Vector3d origin_in_cam_mm = Eigen::Vector3d::Zero();  // CAM coordinates of the workpiece origin
  bool origin_from_mesh = true;  // taken from the mesh (else the scene gave origin_in_cam_mm)
  double spoilboard_mm = 0.0;
  BelowBottom below_bottom;
  std::vector<Peripheral> peripherals;
  SearchSettings search;

  double pad_min_mm() const { return std::max(search.pad_min_mm, spoilboard_mm); }
};

Scene load_scene(const std::string& path);
// The same from the scene's text; `path` names it in messages, and the files it names are
// found relative to path's folder (as if the text had been read from there).
Scene load_scene_text(const std::string& text, const std::string& path);

}  // namespace machplan::placement
