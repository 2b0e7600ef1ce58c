// The position observer between encoder counts (engine/control/position_observer.h), on the
// simulator's own axis (models/axis/plant.h) read through the executor's counter decoder.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "engine/common/error.h"
#include "engine/control/counter_decoder.h"
#include "engine/control/position_observer.h"
#include "models/axis/plant.h"
#include "models/cutting/machine_config.h"

namespace machplan::control {
namespace {

constexpr double kTick_s = 0.001;

// The XY table's X axis as its machine file describes it (2 um counts, a 4 ms drive, one period
// of command and one of reading latency, no backlash here), with friction and noise as asked.
axis::AxisPlantParams table_axis(double noise_mm_per_s, double coulomb_mm_per_s) {
  static const cutting::MachineConfig m = cutting::load_machine(cutting::find_machine("xy_table"));
  axis::AxisPlantParams p = m.axes[0].plant;
  p.coulomb_friction_mm_per_s = coulomb_mm_per_s;
  p.speed_noise_mm_per_s = noise_mm_per_s;
  p.backlash_mm = 0.0;
  return p;
}

struct Errors {
  double reading_rms = 0, reading_max = 0, estimate_rms = 0, estimate_max = 0;
  double prediction_max = 0;  // |predict() - the truth D periods after the reading's instant|
};

// Drives the axis open loop with a slow sine of speed (16 mm/s, reversing twice), decodes the
// counter, and compares the reading and the observer's estimate with the truth at the
// reading's instant.
Errors run_open_loop(const axis::AxisPlantParams& p, double bandwidth_per_s, double model_coulomb,
                     double model_backlash = 0.0) {
  const double x0 = 100.0;
  axis::AxisPlant plant(p, x0, 0);
  CounterDecoder dec;
  dec.configure(p.mm_per_count(), p.counter_bits, 100000);
  dec.reset(0, x0);
  ObserverModel m;
  m.period_s = kTick_s;
  m.gain = p.gain_factor;
  m.tau_s = p.velocity_loop_time_constant_s;
  m.quantum_mm = p.mm_per_count();
  m.coulomb_mm_per_s = model_coulomb;
  m.backlash_mm = model_backlash;
  m.delay_ticks = p.command_latency_ticks + p.reading_latency_ticks;
  PositionObserver obs;
  obs.configure(m, bandwidth_per_s);
  std::mt19937_64 rng(7);
  std::vector<double> truth;  // load position after each step
  Errors e;
  double sy = 0, sx = 0;
  int n = 0;
  std::vector<double> predicted;  // predict() of period k, for the step k - 1 - r + D
  const double full = 32768, fs = p.dac_full_scale_mm_per_s();
  for (int k = 0; k < 8000; ++k) {
    const axis::CounterReading r = plant.read();
    EXPECT_EQ(dec.update(r.value, r.direction_negative), CounterDecoder::Verdict::ok);
    const double y = dec.position_mm();
    const double x = obs.update(y);
    predicted.push_back(obs.predict());
    const int shown = k - 1 - p.reading_latency_ticks;  // the step whose end the reading shows
    if (shown >= 0 && k > 200) {
      const double t = truth[static_cast<std::size_t>(shown)];
      sy += (y - t) * (y - t);
      sx += (x - t) * (x - t);
      e.reading_max = std::max(e.reading_max, std::abs(y - t));
      e.estimate_max = std::max(e.estimate_max, std::abs(x - t));
      ++n;
    }
    const int code = static_cast<int>(std::lround(16.0 * std::sin(2 * M_PI * k * kTick_s / 4.0) / fs * full));
    obs.command(code / full * fs);
    plant.step(code, true, kTick_s, rng);
    truth.push_back(plant.load_position_mm());
  }
  const int D = m.delay_ticks;
  for (int k = 201; k < 8000; ++k) {
    const int at = k - 1 - p.reading_latency_ticks + D;  // the step the prediction is for
    if (at >= 0 && at < static_cast<int>(truth.size()))
      e.prediction_max = std::max(e.prediction_max, std::abs(predicted[static_cast<std::size_t>(k)] - truth[static_cast<std::size_t>(at)]));
  }
  e.reading_rms = std::sqrt(sy / n);
  e.estimate_rms = std::sqrt(sx / n);
  return e;
}

TEST(CounterDecoder, ReportsTheMiddleOfTheCountOnceTheAxisHasMoved) {
  CounterDecoder d;
  d.configure(0.002, 16, 100);
  d.reset(1000, 50.0);
  EXPECT_DOUBLE_EQ(d.position_mm(), 50.0);  // at the reference: known exactly
  ASSERT_EQ(d.update(997, false), CounterDecoder::Verdict::ok);  // 3 edges up: in [x0 + 3q, x0 + 4q)
  EXPECT_NEAR(d.position_mm(), 50.007, 1e-12);
  ASSERT_EQ(d.update(996, true), CounterDecoder::Verdict::ok);  // one edge down: [x0 + 2q, x0 + 3q)
  EXPECT_NEAR(d.position_mm(), 50.005, 1e-12);
}

TEST(PositionObserver, OffPassesTheReadingThrough) {
  PositionObserver o;
  o.configure(ObserverModel{}, 0.0);
  EXPECT_FALSE(o.enabled());
  o.command(5.0);
  EXPECT_EQ(o.update(1.234), 1.234);
  EXPECT_EQ(o.update(-7.0), -7.0);
}

TEST(PositionObserver, RefusesABadModelOrBandwidth) {
  PositionObserver o;
  ObserverModel m;
  m.tau_s = -1;
  EXPECT_THROW(o.configure(m, 10), InputError);
  m = ObserverModel{};
  m.delay_ticks = ObserverModel::kMaxDelayTicks + 1;
  EXPECT_THROW(o.configure(m, 10), InputError);
  EXPECT_THROW(o.configure(ObserverModel{}, -1), InputError);
  EXPECT_THROW(o.configure(ObserverModel{}, std::nan("")), InputError);
}

TEST(PositionObserver, NoiselessDriveIsFollowedWellWithinACount) {
  // No noise, no friction: the model is the plant, so the estimate converges far inside the
  // count the reading can only place to +-q/2 (q = 2 um). A misaligned delay would not.
  const Errors e = run_open_loop(table_axis(0.0, 0.0), 30.0, 0.0);
  EXPECT_NEAR(e.reading_rms, 0.002 / std::sqrt(12.0), 0.0001);  // uniform over one count
  EXPECT_LT(e.estimate_rms, 0.4 * e.reading_rms);
  EXPECT_LE(e.estimate_max, e.reading_max + 0.001 + 1e-12);  // within half a count of the reading
}

TEST(PositionObserver, HalvesTheErrorUnderSpeedNoiseAndFriction) {
  // The XY table's 0.2 mm/s of speed noise and 2 mm/s of Coulomb friction, known to the model.
  const Errors e = run_open_loop(table_axis(0.2, 2.0), 100.0, 2.0);
  EXPECT_LT(e.estimate_rms, 0.6 * e.reading_rms);
  EXPECT_LE(e.estimate_max, e.reading_max + 0.001 + 1e-12);
}

TEST(PositionObserver, PredictsThePositionWhenItsCommandActs) {
  // No noise: the prediction over the commands in flight is the truth D periods on, within the
  // estimate's own error (a few tenths of a count) and nowhere near the 16 um the axis moves
  // per period here.
  const Errors e = run_open_loop(table_axis(0.0, 2.0), 100.0, 2.0);
  EXPECT_LT(e.prediction_max, 0.002);
}

TEST(PositionObserver, KnowingTheBacklashFollowsTheTableThroughReversals) {
  // A 4 um gap between motor and table: the table stands while the motor crosses it at each
  // reversal. A model that knows the gap follows that; one that does not runs ahead.
  axis::AxisPlantParams p = table_axis(0.2, 2.0);
  p.backlash_mm = 0.004;
  const Errors blind = run_open_loop(p, 100.0, 2.0, 0.0), knowing = run_open_loop(p, 100.0, 2.0, 0.004);
  EXPECT_LT(knowing.estimate_rms, blind.estimate_rms);
  EXPECT_LT(knowing.estimate_rms, 0.6 * knowing.reading_rms);
  EXPECT_LE(knowing.estimate_max, knowing.reading_max + 0.001 + 1e-12);
}

TEST(PositionObserver, AStuckAxisDoesNotWindThePredictionUp) {
  // The commands say 50 mm/s, the axis does not move (stuck, or held by hand): the estimate
  // stays within the count the encoder shows, and the disturbance (which would settle at
  // -50 mm/s to explain the standstill) stays within a 20 mm/s range, and the prediction with it.
  ObserverModel m;
  m.tau_s = 0.004;
  m.quantum_mm = 0.002;
  m.delay_ticks = 2;
  m.speed_limit_mm_per_s = 20;
  PositionObserver o;
  o.configure(m, 100.0);
  double d_min = 0.0;
  for (int k = 0; k < 20000; ++k) {
    const double x = o.update(10.0);
    ASSERT_LE(std::abs(x - 10.0), 0.001 + 1e-12) << k;
    ASSERT_LE(std::abs(o.disturbance_mm_per_s()), 20.0) << k;
    ASSERT_LT(std::abs(o.predict() - 10.0), 3 * 0.001 * (50.0 + 20.0)) << k;  // D + 1 periods at most
    d_min = std::min(d_min, o.disturbance_mm_per_s());
    o.command(50.0);
  }
  EXPECT_EQ(d_min, -20.0) << "the bound was reached";
  m.speed_limit_mm_per_s = -1;
  EXPECT_THROW(o.configure(m, 100.0), InputError);
}

TEST(PositionObserver, StaysInsideTheCountWhenTheModelIsWrong) {
  // The model believes in no friction while the axis has 5 mm/s of it and sticks at each
  // reversal: the estimate drifts but the clamp keeps it within half a count of the reading.
  // (The reading itself can be off by more than half a count after a reversal: the table's
  // down counter counts the edges of both directions within one period with the latest one.)
  const Errors e = run_open_loop(table_axis(0.2, 5.0), 100.0, 0.0);
  EXPECT_LE(e.estimate_max, e.reading_max + 0.001 + 1e-12);
}

}  // namespace
}  // namespace machplan::control
