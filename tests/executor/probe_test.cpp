// Initial height sensing alone: the torch sequencer's probe against a hand-made plate and its
// sensors, and the surface map the probes build.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>

#include "engine/executor/surface_map.h"
#include "engine/executor/torch_sequencer.h"
#include "tests/support/torch_plant.h"

namespace machplan::executor {
namespace {

using S = TorchSequencer::Tick;
using Sensor = TorchSequencer::Probe::Sensor;

using test::probing_torch;
using Plate = test::TorchPlant;

struct Probed {
  S status;
  TorchSequencer::Probe probe;
  bool reported;
};

Probed probe_at(TorchSequencer& seq, Plate& p, hardware::Outputs& out, Eigen::Vector2d at = {0, 0}) {
  seq.set_position(at);
  seq.start_on(false, out);
  const S s = test::run_torch(seq, p, out).first;
  TorchSequencer::Probe r;
  const bool reported = seq.take_probe(r);
  return {s, r, reported};
}

TEST(Probe, TheOhmicContactFindsTheSurfaceAndThePierceFiresAtPierceHeightOverIt) {
  TorchSequencer seq;
  seq.configure(probing_torch(true, true), 0.001);
  hardware::Outputs out;
  Plate p;
  p.plate = -2.3;  // the sheet lies lower than the nominal surface
  const Probed r = probe_at(seq, p, out);
  ASSERT_EQ(r.status, S::done);
  ASSERT_TRUE(r.reported);
  EXPECT_EQ(r.probe.sensor, Sensor::ohmic);
  EXPECT_FALSE(r.probe.skipped);
  EXPECT_NEAR(r.probe.surface_mm, -2.3, 0.02);
  EXPECT_NEAR(seq.surface_mm(), -2.3, 0.02);
  EXPECT_NEAR(p.height_at_fire - *p.plate, 3.8, 0.06);
  EXPECT_NEAR(p.height - *p.plate, 1.5, 0.06) << "at cut height over the plate found";
  EXPECT_FALSE(out.ohmic_enable) << "ohmic sensing is on only while probing";
  EXPECT_GT(p.lowest, *p.plate - 0.1) << "the ohmic contact stops the torch at the surface";
  // Fast to 5 mm over the nominal surface, then 7.3 mm at 10 mm/s.
  EXPECT_NEAR(r.probe.duration_s, 10.0 / 50 + 7.3 / 10, 0.02);
}

TEST(Probe, TheFloatSwitchFindsTheSurfaceOneTravelAboveWhereItClosed) {
  TorchSequencer seq;
  seq.configure(probing_torch(false, true), 0.001);
  hardware::Outputs out;
  Plate p;
  p.plate = 1.7;
  const Probed r = probe_at(seq, p, out);
  ASSERT_EQ(r.status, S::done);
  EXPECT_EQ(r.probe.sensor, Sensor::float_switch);
  EXPECT_NEAR(r.probe.surface_mm, 1.7, 0.02);
  EXPECT_LT(p.lowest, 1.7 - 1.5 + 0.01) << "the float switch closes once the torch has floated its travel";
  EXPECT_NEAR(p.height_at_fire - *p.plate, 3.8, 0.06);
}

TEST(Probe, ADirtyPlateLeavesTheOhmicContactOpenAndTheFloatSwitchTakesOver) {
  TorchSequencer seq;
  seq.configure(probing_torch(true, true), 0.001);
  hardware::Outputs out;
  Plate p;
  p.dirty = true;
  const Probed r = probe_at(seq, p, out);
  ASSERT_EQ(r.status, S::done);
  EXPECT_EQ(r.probe.sensor, Sensor::float_switch);
  EXPECT_NEAR(r.probe.surface_mm, 0.0, 0.02);
}

TEST(Probe, ASheetAboveTheProbeHeightIsFoundOnTheWayDownAndProbedAgainSlowly) {
  TorchSequencer seq;
  seq.configure(probing_torch(true, true), 0.001);
  hardware::Outputs out;
  Plate p;
  p.plate = 6.0;  // above the probe height over the nominal surface
  const Probed r = probe_at(seq, p, out);
  ASSERT_EQ(r.status, S::done);
  EXPECT_NEAR(r.probe.surface_mm, 6.0, 0.02) << "found again at the probe speed";
  EXPECT_NEAR(p.height_at_fire - *p.plate, 3.8, 0.06);
}

TEST(Probe, NoSheetWithinTheProbeDepthIsAProbeMissAndTheTorchNeverFires) {
  TorchSequencer seq;
  seq.configure(probing_torch(true, true), 0.001);
  hardware::Outputs out;
  Plate p;
  p.plate.reset();
  const Probed r = probe_at(seq, p, out);
  ASSERT_EQ(r.status, S::failed);
  EXPECT_EQ(seq.failure(), TorchSequencer::Failure::probe_miss);
  EXPECT_DOUBLE_EQ(seq.failure_value(), 5.0);
  EXPECT_FALSE(r.reported);
  EXPECT_TRUE(std::isnan(p.height_at_fire)) << "never fired";
  EXPECT_FALSE(out.ohmic_enable);
  EXPECT_NEAR(p.lowest, -5.0, 0.06) << "down to the probe's depth limit and no further";
}

TEST(Probe, AFloatSwitchClosedBeforeTheProbeIsStuckAndTheTorchDoesNotGoDown) {
  TorchSequencer seq;
  seq.configure(probing_torch(true, true), 0.001);
  hardware::Outputs out;
  Plate p;
  p.float_stuck = true;
  const Probed r = probe_at(seq, p, out);
  ASSERT_EQ(r.status, S::failed);
  EXPECT_EQ(seq.failure(), TorchSequencer::Failure::switch_stuck);
  EXPECT_DOUBLE_EQ(seq.failure_value(), 1.0) << "the float switch, not the ohmic sense";
  EXPECT_GT(p.lowest, 14.0) << "stopped within the debounce, near the retract height";
  EXPECT_TRUE(std::isnan(p.height_at_fire));
}

TEST(Probe, OnePeriodOfAClosedSwitchIsNoContact) {
  TorchSequencer seq;
  seq.configure(probing_torch(false, true), 0.001);
  hardware::Outputs out;
  Plate p;
  p.plate = -1.0;
  p.glitch_at = 600;  // during the slow descent, well above the plate
  const Probed r = probe_at(seq, p, out);
  ASSERT_EQ(r.status, S::done);
  EXPECT_NEAR(r.probe.surface_mm, -1.0, 0.02);
}

TEST(Probe, APierceNearTheLastProbeSkipsItAndTakesTheSurfaceThere) {
  TorchSetup t = probing_torch(true, true);
  t.probe.skip_distance_mm = 10.0;
  TorchSequencer seq;
  seq.configure(t, 0.001);
  hardware::Outputs out;
  Plate p;
  p.plate = 1.0;
  ASSERT_EQ(probe_at(seq, p, out, {100, 100}).status, S::done);
  seq.start_off(out);
  ASSERT_EQ(test::run_torch(seq, p, out).first, S::done);
  // 8 mm away: within the skip distance.
  p.lowest = p.height;
  p.height_at_fire = NAN;
  const Probed near = probe_at(seq, p, out, {108, 100});
  ASSERT_EQ(near.status, S::done);
  ASSERT_TRUE(near.reported);
  EXPECT_TRUE(near.probe.skipped);
  EXPECT_EQ(near.probe.sensor, Sensor::none);
  EXPECT_NEAR(near.probe.surface_mm, 1.0, 0.02);
  EXPECT_GT(p.lowest, 1.0 + 1.5 - 0.06) << "no probe: never below the cut height, after the pierce";
  EXPECT_EQ(near.probe.duration_s, 0.0);
  EXPECT_NEAR(p.height_at_fire - *p.plate, 3.8, 0.06);
  seq.start_off(out);
  ASSERT_EQ(test::run_torch(seq, p, out).first, S::done);
  // 12 mm from the last probed point (skipped pierces do not move it): probed again.
  const Probed far = probe_at(seq, p, out, {112, 100});
  ASSERT_EQ(far.status, S::done);
  EXPECT_FALSE(far.probe.skipped);
  EXPECT_EQ(far.probe.sensor, Sensor::ohmic);
}

TEST(SurfaceMap, APlaneIsRecoveredExactlyFromThreeOrMorePoints) {
  SurfaceMap m(200.0);
  auto plane = [](double x, double y) { return 1.0 + 0.01 * x - 0.02 * y; };
  for (const Eigen::Vector2d& p : {Eigen::Vector2d(0, 0), Eigen::Vector2d(50, 0), Eigen::Vector2d(0, 60), Eigen::Vector2d(40, 40)})
    m.add(p, plane(p.x(), p.y()));
  double z = 0.0;
  // The ridge term takes a few thousandths of the slopes off.
  ASSERT_TRUE(m.estimate({20, 25}, z));
  EXPECT_NEAR(z, plane(20, 25), 0.002);
  ASSERT_TRUE(m.estimate({90, -30}, z));
  EXPECT_NEAR(z, plane(90, -30), 0.03) << "outside the points too (the plane goes on)";
}

TEST(SurfaceMap, PointsOnALineKeepTheirSlopeAlongItAndNoneAcrossAndFarPointsSayNothing) {
  SurfaceMap m(200.0);
  double z = 0.0;
  EXPECT_FALSE(m.estimate({0, 0}, z)) << "empty";
  m.add({0, 0}, 1.0);
  m.add({10, 0}, 2.0);
  m.add({20, 0}, 3.0);
  ASSERT_TRUE(m.estimate({10, 30}, z));
  EXPECT_NEAR(z, 2.0, 0.01) << "no slope across the line";
  ASSERT_TRUE(m.estimate({40, 0}, z));
  EXPECT_NEAR(z, 5.0, 0.3) << "the slope along it (0.1 per mm) goes on, a little flattened by the ridge";
  EXPECT_FALSE(m.estimate({500, 500}, z)) << "no point within the radius";
}

TEST(SurfaceMap, KeepsTheNewestPointsWhenFull) {
  SurfaceMap m(200.0);
  auto grid = [](std::size_t i) { return Eigen::Vector2d(10.0 * (i % 8), 10.0 * (i / 8)); };
  for (std::size_t i = 0; i < SurfaceMap::kCapacity; ++i) m.add(grid(i), 9.0);
  for (std::size_t i = 0; i < SurfaceMap::kCapacity; ++i) m.add(grid(i), -1.0);
  EXPECT_EQ(m.size(), SurfaceMap::kCapacity);
  double z = 0.0;
  ASSERT_TRUE(m.estimate({35, 35}, z));
  EXPECT_NEAR(z, -1.0, 1e-9) << "the older measurements of the same points are gone";
}

}  // namespace
}  // namespace machplan::executor
