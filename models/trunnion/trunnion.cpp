#include "models/trunnion/trunnion.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>

#include "engine/common/error.h"
#include "engine/config/yaml.h"
#include "engine/programs/mesh.h"

namespace machplan::trunnion {

namespace {
// Coordinates and sizes of a machine tool stay well within this (mm).
constexpr double kMaxMm = 100'000.0;

Eigen::Isometry3d rotation_about(const Eigen::Vector3d& point, const Eigen::Vector3d& dir, double angle) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle, dir).toRotationMatrix();
  T.translation() = point - T.linear() * point;
  return T;
}

// Angle turning u onto v about the unit axis k (both projected onto the plane normal to k);
// nullopt when either projection vanishes.
std::optional<double> turn_about(const Eigen::Vector3d& k, const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
  const Eigen::Vector3d up = u - k.dot(u) * k, vp = v - k.dot(v) * k;
  if (up.norm() < 1e-9 || vp.norm() < 1e-9) return std::nullopt;
  return std::atan2(k.dot(up.cross(vp)), up.dot(vp));
}

Eigen::Vector3d unit(const Yaml& y, const std::string& key) {
  const Eigen::Vector3d v = y.vec3(key);
  if (!(v.norm() > 1e-9) || !v.allFinite()) y.at(key).fail("must be a non-zero direction");
  return v.normalized();
}

Eigen::Vector3d position(const Yaml& y, const std::string& key) {
  const Eigen::Vector3d v = y.vec3(key);
  if ((v.array().abs() > kMaxMm).any()) y.at(key).fail(fmt::format("must lie within +-{} mm", kMaxMm));
  return v;
}

const NumberRule kSize{.min = 0, .max = kMaxMm, .min_exclusive = true};
const NumberRule kSpeed{.min = 0, .max = 1e7, .min_exclusive = true};
const NumberRule kAccel{.min = 0, .max = 1e8, .min_exclusive = true};
const NumberRule kJerk{.min = 0, .max = 1e10, .min_exclusive = true};

// An axis's acceleration and jerk (keys `accel_<unit>_per_s2`, `jerk_<unit>_per_s3`): both or
// neither; neither leaves 0 and notes the first such axis in `missing`.
void read_dynamics(const Yaml& y, const std::string& unit, double scale, double& accel, double& jerk,
                   const std::string& axis, Machine& m) {
  const std::string ka = "accel_" + unit + "_per_s2", kj = "jerk_" + unit + "_per_s3";
  if (!y.has(ka) && !y.has(kj)) {
    if (m.dynamics_missing.empty()) {
      m.dynamics_missing = fmt::format("axis {} gives no {} and {}", axis, ka, kj);
      m.dynamics_missing_line = y.line();
    }
    return;
  }
  if (!y.has(ka)) y.at(kj).fail(fmt::format("comes without {} (give both or neither)", ka));
  if (!y.has(kj)) y.at(ka).fail(fmt::format("comes without {} (give both or neither)", kj));
  accel = y.number(ka, kAccel) * scale;
  jerk = y.number(kj, kJerk) * scale;
}

Solid read_solid(const Yaml& y) {
  y.reject_unknown_keys({"name", "box", "cylinder", "mesh", "xyz"});
  Solid s;
  s.name = y.string("name");
  const int kinds = int(y.has("box")) + int(y.has("cylinder")) + int(y.has("mesh"));
  if (kinds != 1) y.fail("needs exactly one of 'box', 'cylinder' or 'mesh'");
  if (const auto b = y.get("box")) {
    b->reject_unknown_keys({"center", "size", "yaw_deg"});
    s.shape = Solid::Shape::box;
    s.centre_mm = position(*b, "center");
    s.size_mm = b->vec3("size");
    if ((s.size_mm.array() <= 0).any() || (s.size_mm.array() > kMaxMm).any())
      b->at("size").fail(fmt::format("must be three positive sizes up to {} mm", kMaxMm));
    s.R = Eigen::AngleAxisd(b->number_or("yaw_deg", 0.0, {.min = -360, .max = 360}) * kDeg, Eigen::Vector3d::UnitZ())
              .toRotationMatrix();
  } else if (const auto c = y.get("cylinder")) {
    c->reject_unknown_keys({"center", "radius_mm", "length_mm", "axis"});
    s.shape = Solid::Shape::cylinder;
    s.centre_mm = position(*c, "center");
    s.radius_mm = c->number("radius_mm", kSize);
    s.length_mm = c->number("length_mm", kSize);
    const Eigen::Vector3d axis = c->has("axis") ? unit(*c, "axis") : Eigen::Vector3d::UnitZ();
    s.R = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis).toRotationMatrix();
  } else {
    s.shape = Solid::Shape::mesh;
    const Mesh mesh = read_stl(y.resolve_path(y.string("mesh")));
    const Eigen::Vector3d at = y.has("xyz") ? position(y, "xyz") : Eigen::Vector3d::Zero();
    for (const auto& v : mesh.vertices) s.vertices.push_back(v + at);
    s.triangles = mesh.triangles;
    if (s.triangles.empty()) y.at("mesh").fail("names a mesh with no triangles");
  }
  return s;
}

std::vector<Solid> read_solids(const Yaml& y, const std::string& key) {
  std::vector<Solid> out;
  if (const auto list = y.get(key))
    for (const Yaml& item : list->items()) out.push_back(read_solid(item));
  return out;
}

RotaryAxis read_rotary(const Yaml& y, std::initializer_list<const char*> keys, Machine& m) {
  y.reject_unknown_keys(keys);
  RotaryAxis r;
  r.name = y.string("name");
  r.point_mm = position(y, "point_mm");
  r.direction = unit(y, "direction");
  r.continuous = y.boolean_or("continuous", false);
  if (!r.continuous) {
    r.min_rad = y.number("min_deg", {.min = -720, .max = 720}) * kDeg;
    r.max_rad = y.number("max_deg", {.min = -720, .max = 720}) * kDeg;
    if (r.max_rad <= r.min_rad) y.at("max_deg").fail("must be larger than min_deg");
  } else if (y.has("min_deg") || y.has("max_deg")) {
    y.fail("a continuous axis has no min_deg or max_deg");
  }
  r.feed_rad_per_s = y.number("feed_deg_per_min", kSpeed) * kDeg / 60.0;
  r.rapid_rad_per_s = y.number("rapid_deg_per_min", kSpeed) * kDeg / 60.0;
  read_dynamics(y, "deg", kDeg, r.accel_rad_per_s2, r.jerk_rad_per_s3, r.name, m);
  r.solids = read_solids(y, "parts");
  return r;
}
}  // namespace

Eigen::Isometry3d Machine::tilt_pose(double a_rad) const { return rotation_about(tilt.point_mm, tilt.direction, a_rad); }

Eigen::Isometry3d Machine::table_pose(double a_rad, double c_rad) const {
  Eigen::Isometry3d T0 = Eigen::Isometry3d::Identity();
  T0.linear() = table_frame;
  T0.translation() = table_origin_mm;
  return tilt_pose(a_rad) * rotation_about(table.point_mm, table.direction, c_rad) * T0;
}

Eigen::Vector3d Machine::axes_for_nose(const Eigen::Vector3d& nose) const {
  const Eigen::Vector3d d = nose - nose_mm;
  return {linear[0].direction.dot(d), linear[1].direction.dot(d), linear[2].direction.dot(d)};
}

std::vector<Angles> solve_angles(const Machine& m, const Eigen::Vector3d& axis, double c_hint) {
  const Eigen::Vector3d& uA = m.tilt.direction;
  const Eigen::Vector3d& uC = m.table.direction;
  const Eigen::Vector3d& s = m.spindle_direction;
  const Eigen::Vector3d a0 = m.table_frame * axis.normalized();
  const double c = uA.dot(uC);
  const double alpha = (uA.dot(s) - c * uC.dot(a0)) / (1 - c * c);
  const double beta = (uC.dot(a0) - c * uA.dot(s)) / (1 - c * c);
  const Eigen::Vector3d w = uA.cross(uC);
  const double g2 = (1 - alpha * alpha - beta * beta - 2 * alpha * beta * c) / w.squaredNorm();
  if (g2 < -1e-9) return {};
  const double gamma = std::sqrt(std::max(0.0, g2));
  std::vector<Angles> out;
  for (const double sign : {1.0, -1.0}) {
    const Eigen::Vector3d z = alpha * uA + beta * uC + sign * gamma * w;
    Angles ang;
    const auto cturn = turn_about(uC, a0, z);
    ang.c_rad = cturn ? *cturn : c_hint;
    // R_A z = s, with z the axis after the C turn.
    const Eigen::Vector3d zc = Eigen::AngleAxisd(ang.c_rad, uC) * a0;
    ang.a_rad = turn_about(uA, zc, s).value_or(0.0);
    out.push_back(ang);
    if (gamma < 1e-12 || !cturn) break;  // one solution (or a free C: the same pose either way)
  }
  return out;
}

Eigen::Vector3d axis_at(const Machine& m, double a_rad, double c_rad) {
  return m.table_pose(a_rad, c_rad).linear().transpose() * m.spindle_direction;
}

Machine machine_from_yaml(const Yaml& root) {
  root.reject_unknown_keys({"kind", "name", "reconstructed", "feed_mode", "spindle", "linear_axes", "tilt_axis", "rotary_table",
                            "base_parts", "tool_change"});
  Machine m;
  m.source = root.file();
  m.name = root.string_or("name", "trunnion");
  const std::string feed_mode = root.string_or("feed_mode", "tcp");
  if (feed_mode != "tcp" && feed_mode != "axes")
    root.at("feed_mode").fail(fmt::format("'{}': must be tcp (the feed is the tool tip's speed relative to the workpiece) "
                                          "or axes (the combined speed of the axes, degrees as mm)",
                                          feed_mode.substr(0, 40)));
  m.feed_on_axes = feed_mode == "axes";
  const Yaml sp = root.at("spindle");
  sp.reject_unknown_keys({"direction", "nose_mm", "parts"});
  m.spindle_direction = unit(sp, "direction");
  m.nose_mm = position(sp, "nose_mm");
  if (const auto parts = sp.get("parts"))
    for (const Yaml& p : parts->items()) {
      p.reject_unknown_keys({"name", "radius_mm", "from_mm", "to_mm"});
      SpindlePart part{p.string("name"), p.number("from_mm", {.min = 0, .max = kMaxMm}), p.number("to_mm", kSize),
                       p.number("radius_mm", kSize)};
      if (part.to_mm <= part.from_mm) p.at("to_mm").fail("must be larger than from_mm");
      m.spindle.push_back(part);
    }
  const Yaml lin = root.at("linear_axes");
  const std::vector<Yaml> items = lin.items();
  if (items.size() != 3) lin.fail("needs three linear axes (X, Y, Z)");
  for (int k = 0; k < 3; ++k) {
    const Yaml& y = items[k];
    y.reject_unknown_keys({"name", "direction", "min_mm", "max_mm", "feed_mm_per_min", "rapid_mm_per_min", "accel_mm_per_s2",
                           "jerk_mm_per_s3"});
    LinearAxis& a = m.linear[k];
    a.name = y.string("name");
    a.direction = unit(y, "direction");
    a.min_mm = y.number("min_mm", {.min = -kMaxMm, .max = kMaxMm});
    a.max_mm = y.number("max_mm", {.min = -kMaxMm, .max = kMaxMm});
    if (a.max_mm <= a.min_mm) y.at("max_mm").fail("must be larger than min_mm");
    a.feed_mm_per_s = y.number("feed_mm_per_min", kSpeed) / 60.0;
    a.rapid_mm_per_s = y.number("rapid_mm_per_min", kSpeed) / 60.0;
    read_dynamics(y, "mm", 1.0, a.accel_mm_per_s2, a.jerk_mm_per_s3, a.name, m);
  }
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j)
      if (std::abs(m.linear[i].direction.dot(m.linear[j].direction)) > 1e-6)
        lin.fail(fmt::format("axes {} and {} must be at right angles", m.linear[i].name, m.linear[j].name));
  m.tilt = read_rotary(root.at("tilt_axis"), {"name", "point_mm", "direction", "continuous", "min_deg", "max_deg",
                                              "feed_deg_per_min", "rapid_deg_per_min", "accel_deg_per_s2", "jerk_deg_per_s3",
                                              "parts"},
                       m);
  const Yaml tab = root.at("rotary_table");
  m.table = read_rotary(tab, {"name", "point_mm", "direction", "continuous", "min_deg", "max_deg", "feed_deg_per_min",
                              "rapid_deg_per_min", "accel_deg_per_s2", "jerk_deg_per_s3", "parts", "radius_mm", "top_mm"},
                        m);
  m.table_radius_mm = tab.number("radius_mm", kSize);
  m.table_origin_mm = position(tab, "top_mm");
  if ((m.table_origin_mm - m.table.point_mm).cross(m.table.direction).norm() > 1e-6)
    tab.at("top_mm").fail("must lie on the rotary table's axis (point_mm + t direction)");
  if (std::abs(m.tilt.direction.dot(m.table.direction)) > 1 - 1e-6)
    root.at("tilt_axis").fail("must not be parallel to the rotary table's axis");
  m.base = read_solids(root, "base_parts");
  // The table frame: z along the table's axis, x along the machine's x as far as it can be.
  const Eigen::Vector3d z = m.table.direction;
  Eigen::Vector3d x = Eigen::Vector3d::UnitX() - z.x() * z;
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitY() - z.y() * z;
  x.normalize();
  m.table_frame.col(0) = x;
  m.table_frame.col(1) = z.cross(x);
  m.table_frame.col(2) = z;
  const Eigen::Vector3d d = m.table_origin_mm - m.tilt.point_mm;
  m.axes_offset_mm = (d - m.tilt.direction.dot(d) * m.tilt.direction).norm();
  return m;
}

Machine load_machine(const std::string& path) { return machine_from_yaml(Yaml::load_file(path)); }

}  // namespace machplan::trunnion
