// Setpoint source of the thermal-cutting paper's modes (Mohamed, Al-Kindi and Hameed, "CNC
// thermal cutting machine", sections 5.4.1 and 5.4.2): each stretch is cut into equal vectors
// of at most `blu_mm` (chords for arcs), and each vector is run as an open-loop SPEED command.
//
//   open loop    vector k runs at speeds F dx/L, F dy/L (times `calibration_factor`) for L/F
//                seconds, with no position feedback; the time left over from one vector is
//                carried into the next.
//   closed loop  at the end of each vector the counters are read, and after a computation
//                time `compute_s` (during which the previous command still runs) the next
//                vector is re-aimed from the measured position to its end point.
//
// Before the first vector of a stretch one period of zero speed goes out (the paper's cure for
// the drives' start shock, `zero_first`); after the last one the command is held at zero for
// `settle_s` before the move counts as done.
#pragma once

#include "engine/executor/setpoint_source.h"

namespace machplan::executor {

struct BluVectorOptions {
  bool closed_loop = false;
  double blu_mm = 3.0;              // vector length, mm: [0.01, 1000]
  double calibration_factor = 1.0;  // commanded / programmed speed: (0.1, 10]
  double compute_s = 0.2;           // closed loop: [0, 10] s
  bool zero_first = true;
  double settle_s = 0.1;            // [0, 60] s
  // Throws InputError naming the field, its value and the rule.
  void validate() const;
};

class BluVectorSource final : public SetpointSource {
 public:
  // Throws InputError when the options do not validate.
  explicit BluVectorSource(const BluVectorOptions& o) : o_(o) { o_.validate(); }
  const char* name() const override { return o_.closed_loop ? "paper-closed" : "paper-open"; }
  void prepare(const SourceContext& ctx, const Eigen::Vector2d& start_mm) override;
  double estimate_s() const override { return estimate_s_; }
  void begin_move(std::size_t step, const Eigen::Vector2d& measured_mm) noexcept override;
  void advance(const Eigen::Vector2d& measured_mm, const hardware::OperatorInputs& op) noexcept override;
  bool move_done() const noexcept override { return done_; }
  bool travelling() const noexcept override { return active_ && !settling_; }
  void demand(Demand& d) const noexcept override;
  int source_line() const noexcept override;

 private:
  void start_vector(std::size_t k, const Eigen::Vector2d& origin) noexcept;
  void vector_tick(const Eigen::Vector2d& measured_mm) noexcept;

  BluVectorOptions o_;
  double dt_ = 0.001;
  double estimate_s_ = 0.0;
  // All vector end points, flat, with the feed and line of the vector ending there.
  std::vector<Eigen::Vector2d> pts_;
  std::vector<double> pt_feed_;
  std::vector<int> pt_line_;
  std::vector<std::size_t> step_first_pt_, step_last_pt_;  // per step: its first and last point
  // State.
  bool active_ = false, settling_ = false, done_ = true;
  double settle_t_ = 0.0;
  std::size_t step_ = 0, pk_ = 0;  // current vector: from pts_[pk_] to pts_[pk_ + 1]
  double left_s_ = 0.0, T_s_ = 0.0, compute_left_s_ = 0.0;
  bool zero_pending_ = false, start_pending_ = false, computing_ = false;
  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero(), latched_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d u_ = Eigen::Vector2d::Zero(), hold_mm_ = Eigen::Vector2d::Zero();
};

}  // namespace machplan::executor
