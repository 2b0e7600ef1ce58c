// A placement problem as the process planner writes it: the machine, the tooling, the
// workpiece and its tool path (in workpiece coordinates), the peripherals on the table and the
// clearance to keep. Read from YAML; every path inside is relative to the scene file.
//
//   machine: machine.yaml
//   safe_distance_mm: 5            # objects are grown by this much (the paper's safe distance)
//   tooling: {tool_diameter_mm: 10, stick_out_mm: 50, flute_length_mm: 20,
//             chuck_diameter_mm: 60, chuck_length_mm: 45}
//   workpiece: {mesh: workpiece.stl}          # or {box: {size: [dx, dy, dz]}}
//   toolpath: toolpath.csv                    # CL (APT) or CSV, workpiece frame
//   peripherals:
//     - {name: tool magazine, box: {center: [x, y, z], size: [dx, dy, dz], yaw_deg: 45}}
//     - {name: fixture, mesh: fixture.stl, pose: {xyz: [x, y, z], yaw_deg: 0}}
//   search: {pad_max_mm: 300, paper_step_mm: 10, paper_pad_step_mm: 10, resolution_mm: 1,
//            max_pose_queries: 3000000}
//
// Bounds: safe_distance_mm 0 .. 1000; tooling sizes, box sizes and pad_max_mm up to
// kMaxSceneSizeMm; peripheral centres and poses within +-kMaxScenePositionMm; yaw_deg
// within +-360; resolution_mm kMinResolutionMm .. kMaxResolutionMm; max_pose_queries 1 .. 1e9.
//
// Workpiece frame: origin at the centre of the workpiece's bottom face, z up. A placement
// (x, y, pad, rotation) puts that origin at (x, y, pad) in the table frame, turned by rotation
// about z; the pad is a block under the workpiece's footprint from the table top to z = pad.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "engine/interference/collision.h"
#include "models/hexam/hexam.h"

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
  double pad_max_mm = 300.0;        // highest pad considered
  double paper_step_mm = 10.0;      // the paper's evasion step
  double paper_pad_step_mm = 10.0;  // the paper's pad increment
  double reversal_deg = 150.0;      // evasion directions further apart than this raise the pad
  // Grid of the optimal search (x, y and pad), kMinResolutionMm .. kMaxResolutionMm. The
  // search's work grows about as 1 / resolution^2 (the placements it examines near the
  // answer): on the bundled scene 1 mm examines about 2e4 placements, 0.1 mm 8e5 (about ten
  // times the time), 0.02 mm 2.6e7 (minutes). A finer grid than 0.1 mm is finer than a
  // workpiece is set on a machine table, so it is refused rather than searched.
  double resolution_mm = 1.0;
  int paper_max_steps = 2000;       // the paper's search gives up after this many moves
  // Work limit of one checker call (one `check`, one decision of the search): exact pose
  // queries. An ordinary check of the bundled scene makes about 3e4; past the limit the call
  // stops with Infeasible (exit 3) naming this key.
  long max_pose_queries = 3'000'000;
};

// The optimal search's grid, mm (SearchSettings::resolution_mm).
inline constexpr double kMinResolutionMm = 0.1;
inline constexpr double kMaxResolutionMm = 100.0;

// Upper bounds on the scene's sizes and positions (mm). No machine tool reaches them; beyond
// them the geometry's squares and sums lose all precision or overflow.
inline constexpr double kMaxSceneSizeMm = 10'000.0;      // tools, peripherals, pads
inline constexpr double kMaxScenePositionMm = 100'000.0;  // peripheral positions
// The checker keeps one bit per constraint (4 of the machine, 2 per peripheral) in a 32-bit mask.
inline constexpr std::size_t kMaxPeripherals = 14;

struct Scene {
  std::string source;
  hexam::Machine machine;
  hexam::Tooling tooling;
  double safe_distance_mm = 5.0;
  std::string toolpath_file;
  std::string workpiece_file;  // the STL, when the workpiece is a mesh; empty for a box
  std::vector<Eigen::Vector3d> tips_mm;  // workpiece frame
  std::vector<Eigen::Vector3d> axes;     // unit
  // Workpiece solid in its own frame.
  std::vector<Eigen::Vector3d> workpiece_vertices;
  std::vector<Eigen::Vector3i> workpiece_triangles;
  Eigen::AlignedBox3d workpiece_bounds;
  std::vector<Peripheral> peripherals;
  SearchSettings search;
};

Scene load_scene(const std::string& path);
// The same from the scene's text; `path` names it in messages, and the files it names are
// found relative to path's folder (as if the text had been read from there).
Scene load_scene_text(const std::string& text, const std::string& path);

}  // namespace machplan::placement
