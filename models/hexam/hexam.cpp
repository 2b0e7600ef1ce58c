#include "models/hexam/hexam.h"
#include "engine/common/internal/numbers.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/LU>

#include "engine/common/error.h"
#include "engine/config/yaml.h"
#include "engine/interference/collision.h"

namespace machplan::hexam {

namespace {

double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}
}  // namespace

Eigen::Matrix3d plate_rotation(const Eigen::Vector3d& axis) {
  return Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis).toRotationMatrix();
}

double plate_rotation_factor(double max_tilt_rad) {
  // The smallest-rotation field R(a) turns at most |da| / cos(tilt / 2) per unit change of a.
  const double half = std::min(max_tilt_rad, M_PI * 0.9) / 2.0;
  return 1.0 / std::cos(half);
}

IkResult inverse_kinematics(const Machine& m, const Eigen::Vector3d& tip_mm, const Eigen::Vector3d& axis) {
  IkResult r;
  r.R = plate_rotation(axis);
  r.plate_centre_mm = tip_mm + m.gauge_mm * axis;
  for (int i = 0; i < 6; ++i) {
    const Strut& st = m.struts[i];
    StrutState& out = r.struts[i];
    out.plate_mm = r.plate_centre_mm + r.R * st.plate_joint_mm;
    const RailPosition on_rail = slider_on_rail(st, out.plate_mm - st.rail_foot_mm);
    if (!on_rail.reachable) {
      r.reachable = false;
      r.reach_deficit_mm = std::max(r.reach_deficit_mm, on_rail.deficit_mm);
    }
    out.s_mm = on_rail.s_mm;
    out.slider_mm = st.rail_foot_mm + out.s_mm * st.rail_direction;
  }
  return r;
}

RailPosition slider_on_rail(const Strut& st, const Eigen::Vector3d& d_mm) {
  const Eigen::Vector3d& d = d_mm;
  const double ud = st.rail_direction.dot(d);
  // Distance from the plate joint to the rail line; the strut must be at least that long.
  const double perp2 = d.squaredNorm() - ud * ud;
  const double disc = st.length_mm * st.length_mm - perp2;
  if (disc < 0) return {ud, false, std::sqrt(perp2) - st.length_mm};
  return {ud + std::sqrt(disc), true, 0.0};
}

double strut_clearance(const Machine& m, const IkResult& ik, int* a, int* b) {
  // Capsules of one radius: their clearance is their axes' distance, in closed form, less two radii.
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 6; ++i)
    for (int j = i + 1; j < 6; ++j) {
      const double dist = interference::segment_distance(ik.struts[i].slider_mm, ik.struts[i].plate_mm,
                                                         ik.struts[j].slider_mm, ik.struts[j].plate_mm) -
                          2 * m.strut_radius_mm;
      if (dist < best) {
        best = dist;
        if (a) *a = i;
        if (b) *b = j;
      }
    }
  return best;
}

double strut_rail_angle(const Machine& m, const IkResult& ik) {
  if (!ik.reachable) return m.alpha_max_rad;
  double cmin = 1.0;
  for (int i = 0; i < 6; ++i) {
    const StrutState& s = ik.struts[i];
    cmin = std::min(cmin, std::abs(m.struts[i].rail_direction.dot(s.plate_mm - s.slider_mm)) / m.struts[i].length_mm);
  }
  return std::acos(std::clamp(cmin, 0.0, 1.0));
}

double slider_rate_bound(const Machine& m, double angle_rad) {
  return 1.0 / std::cos(std::min(angle_rad, m.alpha_max_rad));
}

LimitMargins limit_margins(const Machine& m, const IkResult& ik, bool joints) {
  LimitMargins lm;
  lm.stroke_mm = std::numeric_limits<double>::infinity();
  lm.joint_rad = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 6; ++i) {
    const StrutState& s = ik.struts[i];
    const double stroke = std::min(s.s_mm - m.stroke_min_mm, m.stroke_max_mm - s.s_mm);
    if (stroke < lm.stroke_mm) {
      lm.stroke_mm = stroke;
      lm.stroke_strut = i;
    }
    if (!joints) continue;
    const Eigen::Vector3d dir = (s.plate_mm - s.slider_mm).normalized();
    const double base = m.slider_joint_half_angle_rad - angle_between(dir, m.home_dir_base[i]);
    const double plate = m.plate_joint_half_angle_rad - angle_between(ik.R.transpose() * dir, m.home_dir_plate[i]);
    if (base < lm.joint_rad) {
      lm.joint_rad = base;
      lm.joint_strut = i;
      lm.joint_at_plate = false;
    }
    if (plate < lm.joint_rad) {
      lm.joint_rad = plate;
      lm.joint_strut = i;
      lm.joint_at_plate = true;
    }
  }
  return lm;
}

std::optional<PlatePose> forward_kinematics(const Machine& m, const std::array<double, 6>& s_mm,
                                            const PlatePose& guess, int max_iterations) {
  PlatePose p = guess;
  for (int it = 0; it < max_iterations; ++it) {
    Eigen::Matrix<double, 6, 1> f;
    Eigen::Matrix<double, 6, 6> J;
    for (int i = 0; i < 6; ++i) {
      const Strut& st = m.struts[i];
      const Eigen::Vector3d S = st.rail_foot_mm + s_mm[i] * st.rail_direction;
      const Eigen::Vector3d Rp = p.R * st.plate_joint_mm;
      const Eigen::Vector3d e = S - (p.centre_mm + Rp);
      f(i) = e.squaredNorm() - st.length_mm * st.length_mm;
      // d f = -2 e . (dc + w x Rp) = -2 e . dc - 2 (Rp x e) . w
      J.block<1, 3>(i, 0) = -2.0 * e.transpose();
      J.block<1, 3>(i, 3) = -2.0 * Rp.cross(e).transpose();
    }
    if (f.cwiseAbs().maxCoeff() < 1e-9) return p;
    Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(J);
    if (!lu.isInvertible()) return std::nullopt;
    const Eigen::Matrix<double, 6, 1> step = lu.solve(-f);
    p.centre_mm += step.head<3>();
    const Eigen::Vector3d w = step.tail<3>();
    if (w.norm() > 0) p.R = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() * p.R;
  }
  return std::nullopt;
}

void Machine::finalize(const Yaml* where) {
  auto fail = [&](const std::string& msg) {
    if (where) where->fail(msg);
    throw InputError(source, 0, msg);
  };
  if (gauge_mm <= 0) fail("needs tooling: the gauge length (tool + chuck + head) must be positive");
  const IkResult home = inverse_kinematics(*this, home_tip_mm, Eigen::Vector3d::UnitZ());
  if (!home.reachable)
    fail(fmt::format("home pose (tip {:.1f}, {:.1f}, {:.1f}, axis +z) is out of reach by {:.1f} mm",
                     home_tip_mm.x(), home_tip_mm.y(), home_tip_mm.z(), home.reach_deficit_mm));
  double alpha_max = 0;
  for (int i = 0; i < 6; ++i) {
    const auto& s = home.struts[i];
    if (s.s_mm < stroke_min_mm || s.s_mm > stroke_max_mm)
      fail(fmt::format("home pose puts slider {} at {:.1f} mm, outside the stroke [{}, {}]", i + 1,
                       s.s_mm, stroke_min_mm, stroke_max_mm));
    home_dir_base[i] = (s.plate_mm - s.slider_mm).normalized();
    home_dir_plate[i] = home_dir_base[i];  // R = I at home
    // Angle between the strut (pointing down from the slider) and the rail line.
    const double a = angle_between(-home_dir_base[i], -struts[i].rail_direction);
    alpha_max = std::max(alpha_max, std::min(a, M_PI - a) + slider_joint_half_angle_rad);
  }
  if (alpha_max >= 80.0 * kDeg)
    fail(fmt::format("struts may reach {:.1f} deg from their rails within the joint cones; the "
                     "model needs less than 80 deg to bound slider speed",
                     alpha_max / kDeg));
  kappa = 1.0 / std::cos(alpha_max);
  alpha_max_rad = alpha_max;
  plate_joint_reach_mm = 0;
  for (const auto& s : struts)
    plate_joint_reach_mm = std::max(plate_joint_reach_mm, (Eigen::Vector3d(0, 0, gauge_mm) + s.plate_joint_mm).norm());
  rigid_reach_mm = plate_joint_reach_mm + hinge_radius_mm;
  rigid_reach_mm = std::max(rigid_reach_mm, std::hypot(gauge_mm + plate_thickness_mm, plate_radius_mm));
  for (const auto& p : tool_parts) rigid_reach_mm = std::max(rigid_reach_mm, std::hypot(p.to_mm, p.radius_mm) + p.radius_mm);
}

Machine machine_from_yaml(const Yaml& root) {
  root.reject_unknown_keys({"kind", "name", "table_size_mm", "layout", "struts", "sliders", "spindle", "home_tip_mm",
                            "max_tilt_deg", "tool_change", "reconstructed"});
  if (root.has("kind") && root.string("kind") != "hexapod") root.at("kind").fail("must be 'hexapod' in a HexaM-type machine file");
  Machine m;
  m.source = root.file();
  m.name = root.string_or("name", "hexam");
  m.table_size_mm = root.at("table_size_mm").vec2();
  if (m.table_size_mm.minCoeff() <= 0) root.at("table_size_mm").fail("must be positive");

  const Yaml lay = root.at("layout");
  lay.reject_unknown_keys({"base_radius_mm", "base_pair_half_angle_deg", "rail_foot_z_mm", "rail_inclination_deg",
                           "plate_joint_radius_mm", "plate_pair_half_angle_deg", "strut_length_mm",
                           "first_rail_pair_deg"});
  const NumberRule pos{.min = 0, .min_exclusive = true};
  const double Rb = lay.number("base_radius_mm", pos);
  const double phib = lay.number("base_pair_half_angle_deg", {.min = 0, .max = 59}) * kDeg;
  const double zb = lay.number("rail_foot_z_mm");
  const double incl = lay.number("rail_inclination_deg", {.min = -60, .max = 60}) * kDeg;
  const double Rp = lay.number("plate_joint_radius_mm", pos);
  const double phip = lay.number("plate_pair_half_angle_deg", {.min = 0, .max = 59}) * kDeg;
  const double L = lay.number("strut_length_mm", pos);
  const double th0 = lay.number_or("first_rail_pair_deg", 90.0, {.min = -360, .max = 360});
  // Three rail pairs at th0, th0 + 120 and th0 + 240 deg (90, 210, 330 unless the layout
  // says otherwise); three plate joint pairs half-way between them. Each
  // rail's strut goes to the nearer joint of the neighbouring plate pair (the usual crossed
  // 6-6 layout, which keeps the platform away from singular poses).
  for (int k = 0; k < 3; ++k) {
    const double th = (th0 + 120.0 * k) * kDeg;
    for (int side = 0; side < 2; ++side) {
      const double sgn = side == 0 ? 1.0 : -1.0;
      const double tb = th + sgn * phib;
      const double tp = th + sgn * (60.0 * kDeg - phip);
      Strut& s = m.struts[2 * k + side];
      s.rail_foot_mm = {Rb * std::cos(tb), Rb * std::sin(tb), zb};
      s.rail_direction = Eigen::Vector3d(-std::sin(incl) * std::cos(tb), -std::sin(incl) * std::sin(tb), std::cos(incl));
      s.plate_joint_mm = {Rp * std::cos(tp), Rp * std::sin(tp), 0.0};
      s.length_mm = L;
    }
  }
  const Yaml struts = root.at("struts");
  struts.reject_unknown_keys({"radius_mm", "slider_joint_half_angle_deg", "plate_joint_half_angle_deg"});
  m.strut_radius_mm = struts.number("radius_mm", pos);
  m.slider_joint_half_angle_rad = struts.number("slider_joint_half_angle_deg", {.min = 1, .max = 89}) * kDeg;
  m.plate_joint_half_angle_rad = struts.number("plate_joint_half_angle_deg", {.min = 1, .max = 89}) * kDeg;
  const Yaml sl = root.at("sliders");
  const std::vector<const char*> dynamics = {"feed_mm_per_min", "rapid_mm_per_min", "accel_mm_per_s2", "jerk_mm_per_s3"};
  std::vector<const char*> keys = {"stroke_min_mm", "stroke_max_mm"};
  keys.insert(keys.end(), dynamics.begin(), dynamics.end());
  sl.reject_unknown_keys(keys);
  m.stroke_min_mm = sl.number("stroke_min_mm");
  m.stroke_max_mm = sl.number("stroke_max_mm");
  if (m.stroke_max_mm <= m.stroke_min_mm) sl.at("stroke_max_mm").fail("must be larger than stroke_min_mm");
  m.sliders_line = sl.line();
  const long given = std::count_if(dynamics.begin(), dynamics.end(), [&](const char* k) { return sl.has(k); });
  if (given > 0) {
    for (const char* k : dynamics)
      if (!sl.has(k)) sl.fail(fmt::format("gives {} of the sliders' feed_mm_per_min, rapid_mm_per_min, accel_mm_per_s2 "
                                          "and jerk_mm_per_s3 but not {}: give all four or none", given, k));
    const NumberRule rate{.min = 0, .max = 1e10, .min_exclusive = true};
    m.slider_feed_mm_per_s = sl.number("feed_mm_per_min", rate) / 60.0;
    m.slider_rapid_mm_per_s = sl.number("rapid_mm_per_min", rate) / 60.0;
    m.slider_accel_mm_per_s2 = sl.number("accel_mm_per_s2", rate);
    m.slider_jerk_mm_per_s3 = sl.number("jerk_mm_per_s3", rate);
  }
  const Yaml sp = root.at("spindle");
  sp.reject_unknown_keys({"head_diameter_mm", "head_length_mm", "plate_diameter_mm", "plate_thickness_mm",
                          "hinge_radius_mm"});
  m.tool_parts.push_back({"spindle head", 0, sp.number("head_length_mm", pos), sp.number("head_diameter_mm", pos) / 2,
                          false, ToolPart::Class::class1});
  m.plate_radius_mm = sp.number("plate_diameter_mm", pos) / 2;
  m.plate_thickness_mm = sp.number("plate_thickness_mm", pos);
  m.hinge_radius_mm = sp.number("hinge_radius_mm", pos);
  m.home_tip_mm = root.at("home_tip_mm").vec3();
  m.max_tilt_rad = root.number_or("max_tilt_deg", 60, {.min = 0, .max = 89}) * kDeg;
  return m;
}

Machine load_machine(const std::string& path) { return machine_from_yaml(Yaml::load_file(path)); }

}  // namespace machplan::hexam

namespace machplan::hexam {

void attach_tooling(Machine& m, const Tooling& t) {
  if (t.flute_length_mm > t.stick_out_mm) throw InputError(m.source, 0, "tool flute length exceeds its stick-out");
  // The head entry (loaded from the machine file) is kept and moved up above the chuck.
  ToolPart head = m.tool_parts.back();
  const double head_len = head.to_mm - head.from_mm;
  m.tool_parts = tool_stack(t);
  head.from_mm = t.stick_out_mm + t.chuck_length_mm;
  head.to_mm = head.from_mm + head_len;
  m.tool_parts.push_back(head);
  m.gauge_mm = head.to_mm;
  m.finalize();
}

}  // namespace machplan::hexam
