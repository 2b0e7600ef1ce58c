// Small, exact trajectories for executor tests, standing in for the feed planner so that the
// executor is tested on motion whose every sample is known in closed form. Both are rest-to-rest with a smooth, jerk-limited speed profile:
//
//   acceleration phase (0 <= t <= Ta):  a(t) = (Ap / 2) (1 - cos(2 pi t / Ta))
//                                       v(t) = (Ap / 2) (t - Ta / (2 pi) sin(2 pi t / Ta))
//                                       s(t) = (Ap / 2) (t^2 / 2 + (Ta / 2 pi)^2 (cos(2 pi t / Ta) - 1))
//   with Ta = 2 V / Ap, so v(Ta) = V and s(Ta) = V Ta / 2; peak jerk Ap pi / Ta;
//   cruise at V; deceleration mirrors the acceleration. A distance too short for cruise lowers
//   V to sqrt(D Ap / 2).
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "engine/geometry/contour.h"
#include "engine/motion/job.h"
#include "tests/support/stretches.h"

namespace machplan::test {

class SpeedProfile {
 public:
  SpeedProfile(double distance_mm, double speed_mm_per_s, double accel_mm_per_s2) : D_(distance_mm), Ap_(accel_mm_per_s2) {
    V_ = std::min(speed_mm_per_s, std::sqrt(std::max(D_, 0.0) * Ap_ / 2.0));
    Ta_ = V_ > 0 ? 2.0 * V_ / Ap_ : 0.0;
    Tc_ = V_ > 0 ? std::max(0.0, (D_ - V_ * Ta_) / V_) : 0.0;
  }
  double duration_s() const { return 2 * Ta_ + Tc_; }
  double peak_speed() const { return V_; }
  void eval(double t, double& s, double& v, double& a) const {
    t = std::clamp(t, 0.0, duration_s());
    if (V_ <= 0) {
      s = D_, v = a = 0;
      return;
    }
    if (t <= Ta_) {
      acc(t, s, v, a);
    } else if (t <= Ta_ + Tc_) {
      s = V_ * Ta_ / 2 + V_ * (t - Ta_), v = V_, a = 0;
    } else {
      double s1, v1, a1;
      acc(duration_s() - t, s1, v1, a1);
      s = D_ - s1, v = v1, a = -a1;
    }
  }

 private:
  void acc(double t, double& s, double& v, double& a) const {
    const double w = 2 * M_PI / Ta_;
    a = Ap_ / 2 * (1 - std::cos(w * t));
    v = Ap_ / 2 * (t - std::sin(w * t) / w);
    s = Ap_ / 2 * (t * t / 2 + (std::cos(w * t) - 1) / (w * w));
  }
  double D_, Ap_, V_ = 0, Ta_ = 0, Tc_ = 0;
};

class LineTrajectory final : public motion::Trajectory {
 public:
  LineTrajectory(Eigen::Vector2d from, Eigen::Vector2d to, double speed, double accel)
      : a_(from), u_((to - from).norm() > 0 ? Eigen::Vector2d((to - from).normalized()) : Eigen::Vector2d::UnitX()),
        p_((to - from).norm(), speed, accel) {}
  double duration_s() const override { return p_.duration_s(); }
  void sample(double t, motion::Setpoint& out) const override {
    double s, v, a;
    p_.eval(t, s, v, a);
    out.position_mm = a_ + s * u_;
    out.velocity_mm_per_s = v * u_;
    out.acceleration_mm_per_s2 = a * u_;
  }

 private:
  Eigen::Vector2d a_, u_;
  SpeedProfile p_;
};

// An arc (or several turns) about `center` from angle `start_rad` through signed `sweep_rad`.
class ArcTrajectory final : public motion::Trajectory {
 public:
  ArcTrajectory(Eigen::Vector2d center, double radius, double start_rad, double sweep_rad, double speed, double accel)
      : c_(center), R_(radius), t0_(start_rad), sgn_(sweep_rad >= 0 ? 1.0 : -1.0),
        p_(radius * std::abs(sweep_rad), speed, accel) {}
  double duration_s() const override { return p_.duration_s(); }
  void sample(double t, motion::Setpoint& out) const override {
    double s, v, a;
    p_.eval(t, s, v, a);
    const double th = t0_ + sgn_ * s / R_;
    const Eigen::Vector2d radial(std::cos(th), std::sin(th));
    const Eigen::Vector2d tangent = sgn_ * Eigen::Vector2d(-std::sin(th), std::cos(th));
    out.position_mm = c_ + R_ * radial;
    out.velocity_mm_per_s = v * tangent;
    out.acceleration_mm_per_s2 = a * tangent - (v * v / R_) * radial;
  }

 private:
  Eigen::Vector2d c_;
  double R_, t0_, sgn_;
  SpeedProfile p_;
};

// Polyline through points, each leg rest-to-rest (one LineTrajectory per leg, chained).
class ChainTrajectory final : public motion::Trajectory {
 public:
  void add(std::unique_ptr<motion::Trajectory> t) {
    start_.push_back(total_);
    total_ += t->duration_s();
    parts_.push_back(std::move(t));
  }
  double duration_s() const override { return total_; }
  void sample(double t, motion::Setpoint& out) const override {
    std::size_t i = 0;
    while (i + 1 < parts_.size() && t >= start_[i + 1]) ++i;
    parts_[i]->sample(t - start_[i], out);
  }

 private:
  std::vector<std::unique_ptr<motion::Trajectory>> parts_;
  std::vector<double> start_;
  double total_ = 0;
};

// A job of one cut: torch on, the cutting stretch, torch off. Trajectory for the move only.
struct OneCut {
  motion::Job job;
  std::vector<std::unique_ptr<motion::Trajectory>> trajectories;
};
inline OneCut one_cut(motion::Stretch cut, std::unique_ptr<motion::Trajectory> traj, const char* source = "test.ngc") {
  OneCut o;
  o.job.source = source;
  o.job.start_mm = cut.segments.front().start;
  o.job.stretches.push_back(std::move(cut));
  o.job.steps.push_back({motion::Step::Kind::torch_on, 5, 0, 0.0});
  o.job.steps.push_back({motion::Step::Kind::move, 10, 0, 0.0});
  o.job.steps.push_back({motion::Step::Kind::torch_off, 99, 0, 0.0});
  o.trajectories.resize(3);
  o.trajectories[1] = std::move(traj);
  return o;
}

}  // namespace machplan::test
