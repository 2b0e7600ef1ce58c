// ZPETC (engine/control/zpetc_controller.h): the design on hand-computed polynomials, the zero
// phase property on the drive model, and tracking on an exact discrete simulation of it.
#include <complex>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/control/zpetc_controller.h"

namespace machplan::control {
namespace {

std::complex<double> eval(const std::vector<double>& p, std::complex<double> zinv) {
  std::complex<double> s = 0, x = 1;
  for (double c : p) {
    s += c * x;
    x *= zinv;
  }
  return s;
}

TEST(ZpetcDesign, ZeroOutsideTheUnitCircleIsMirroredNotCancelled) {
  // G = z^-1 (1 + 2 z^-1) / (1 - 0.5 z^-1): zero at -2.
  // ZPETC = (1 - 0.5 z^-1)(2 + z^-1) / 3^2 = (2 - 0.5 z^-2) / 9, applied to r[k + 2].
  const ZpetcDesign z = design_zpetc({1, 2}, {1, -0.5}, 1, 0.9);
  ASSERT_EQ(z.numerator.size(), 3u);
  EXPECT_NEAR(z.numerator[0], 2.0 / 9, 1e-12);
  EXPECT_NEAR(z.numerator[1], 0.0, 1e-12);
  EXPECT_NEAR(z.numerator[2], -0.5 / 9, 1e-12);
  ASSERT_EQ(z.denominator.size(), 1u);
  EXPECT_NEAR(z.denominator[0], 1.0, 1e-12);
  EXPECT_EQ(z.lead, 2);
  EXPECT_EQ(z.uncancelled_zeros, 1);
  EXPECT_EQ(z.cancelled_zeros, 0);
}

TEST(ZpetcDesign, ZeroWellInsideIsCancelledExactly) {
  // G = z^-1 2 (1 - 0.5 z^-1) / (1 - 0.2 z^-1): the inverse (1 - 0.2 z^-1) / (2 - z^-1), r[k + 1].
  const ZpetcDesign z = design_zpetc({2, -1}, {1, -0.2}, 1, 0.9);
  ASSERT_EQ(z.numerator.size(), 2u);
  EXPECT_NEAR(z.numerator[0], 1.0, 1e-12);
  EXPECT_NEAR(z.numerator[1], -0.2, 1e-12);
  ASSERT_EQ(z.denominator.size(), 2u);
  EXPECT_NEAR(z.denominator[0], 2.0, 1e-12);
  EXPECT_NEAR(z.denominator[1], -1.0, 1e-12);
  EXPECT_EQ(z.lead, 1);
  EXPECT_EQ(z.cancelled_zeros, 1);
}

TEST(ZpetcDesign, RefusesWhatCannotBeInverted) {
  EXPECT_THROW(design_zpetc({0, 1}, {1}, 1, 0.9), InputError);
  EXPECT_THROW(design_zpetc({1, -1}, {1}, 1, 0.9), InputError);  // zero at 1: no DC gain
  EXPECT_THROW(design_zpetc({1}, {1}, -1, 0.9), InputError);
  EXPECT_THROW(design_zpetc({1}, {1}, 1, 1.5), InputError);
  EXPECT_THROW(proportional_loop_model(0, 0.004, 1, 0.001, 2), InputError);
}

// The drive model of the XY table: its zero is near -1 and is left uncancelled; the cascade
// closed loop x ZPETC is then real, positive and at most 1 at every frequency, 1 at DC.
TEST(ZpetcDesign, CascadeWithTheDriveModelHasZeroPhase) {
  const DiscreteModel m = proportional_loop_model(150, 0.004, 1.0, 0.001, 2);
  EXPECT_EQ(m.d, 3);
  const double zero = -m.b[1] / m.b[0];
  EXPECT_LT(zero, -0.9);
  EXPECT_GT(zero, -1.0);
  const ZpetcDesign z = design_zpetc(m.b, m.a, m.d, 0.9);
  EXPECT_EQ(z.uncancelled_zeros, 1);
  for (double w : {0.0, 0.01, 0.1, 0.5, 1.0, 2.0, 3.0}) {
    const std::complex<double> zinv = std::polar(1.0, -w);
    // G(z) F(z) z^lead: G = z^-d B / A, F = num / den.
    const std::complex<double> h = std::pow(zinv, m.d) * eval(m.b, zinv) / eval(m.a, zinv) * eval(z.numerator, zinv) /
                                   eval(z.denominator, zinv) * std::pow(zinv, -z.lead);
    EXPECT_NEAR(h.imag(), 0.0, 1e-9) << w;
    EXPECT_GT(h.real(), 0.0) << w;
    EXPECT_LE(h.real(), 1.0 + 1e-12) << w;
    if (w == 0.0) { EXPECT_NEAR(h.real(), 1.0, 1e-12); }
  }
}

// An exact discrete simulation of the loop the ZPETC inverts: first-order drive (tau, g),
// one period of command and one of reading latency, the executor's ordering.
struct DiscreteAxis {
  double tau = 0.004, g = 1.0, T = 0.001;
  double x = 0, v = 0;
  std::vector<double> u_line = std::vector<double>(1, 0.0);  // command latency 1
  std::vector<double> x_past = std::vector<double>(2, 0.0);  // reading latency 1
  void step(double u_now) {
    const double a = std::exp(-T / tau);
    const double u = u_line.front();  // the command written one period ago
    u_line.erase(u_line.begin());
    u_line.push_back(u_now);
    x += tau * (1 - a) * v + g * u * (T - tau * (1 - a));
    v = a * v + (1 - a) * g * u;
    x_past.erase(x_past.begin());
    x_past.push_back(x);
  }
  double reading() const { return x_past.front(); }
};

// Max |r - y| over the last second of a 2 s, 2 Hz, 10 mm sine, with the controller given a
// preview of `preview` periods.
double sine_tracking_error(Controller& c, int preview) {
  std::array<DiscreteAxis, kAxes> ax;
  c.reset();
  const double T = 0.001, w = 2 * M_PI * 2;
  auto rd = [&](double t) { return 10 * std::sin(w * t); };
  double worst = 0;
  for (int k = 0; k < 2000; ++k) {
    ControllerInput in;
    const double t = (k - 1) * T;  // r at the instant of the (one period old) reading
    for (int i = 0; i < kAxes; ++i) {
      in.r_mm[i] = rd(t);
      in.v_ff_mm_per_s[i] = 10 * w * std::cos(w * (t + 3 * T));
      in.a_ff_mm_per_s2[i] = -10 * w * w * std::sin(w * (t + 3 * T));
      in.y_mm[i] = ax[i].reading();
      for (int j = 0; j < preview; ++j) in.r_preview_mm[j][i] = rd(t + (j + 1) * T);
    }
    in.preview_ticks = preview;
    ControllerOutput out;
    c.update(in, out);
    if (k >= 1000) worst = std::max(worst, std::abs(in.r_mm[0] - in.y_mm[0]));
    for (int i = 0; i < kAxes; ++i) ax[i].step(out.u_mm_per_s[i]);
  }
  return worst;
}

TEST(ZpetcController, TracksASineOnItsModelFarBetterThanItsPLoop) {
  ZpetcAxisOptions o;
  o.kp_per_s = 150;
  o.model_time_constant_s = 0.004;
  o.latency_ticks = 2;
  ZpetcController z;
  z.configure({o, o}, {1000, 1000}, 0.001);
  const double e_preview = sine_tracking_error(z, ControllerInput::kMaxPreviewTicks);
  const double e_extrapolated = sine_tracking_error(z, 0);
  // The bare P loop for comparison: r* = r.
  struct PLoop final : Controller {
    const char* name() const override { return "p"; }
    void reset() override {}
    void update(const ControllerInput& in, ControllerOutput& out) noexcept override {
      for (int i = 0; i < kAxes; ++i) out.u_mm_per_s[i] = 150 * (in.r_mm[i] - in.y_mm[i]);
    }
    double following_error_mm(int) const noexcept override { return 0; }
    bool following_error_exceeded(int) const noexcept override { return false; }
    bool saturated(int) const noexcept override { return false; }
  } p;
  const double e_p = sine_tracking_error(p, 0);
  std::printf("2 Hz 10 mm sine: P %.5f mm, ZPETC with preview %.6f mm, extrapolated %.6f mm\n", e_p, e_preview,
              e_extrapolated);
  EXPECT_GT(e_p, 0.5);  // 10 mm * 12.6 /s / 150 /s = 0.84 mm of lag
  EXPECT_LT(e_preview, e_p / 1000);  // what is left is the uncancelled zero's gain loss, ~4e-4 mm
  EXPECT_LT(e_extrapolated, e_p / 20);
}

TEST(ZpetcController, FilterOfTheDriveModelNeedsFourPeriodsOfPreview) {
  ZpetcAxisOptions o;
  ZpetcController z;
  z.configure({o, o}, {1000, 1000}, 0.001);
  EXPECT_EQ(z.design(0).lead, 4);  // d = 2 latency + 1, one uncancelled zero
  EXPECT_LE(z.design(0).lead, ControllerInput::kMaxPreviewTicks);
  o.latency_ticks = 30;
  EXPECT_THROW(z.configure({o, o}, {1000, 1000}, 0.001), InputError);
}

}  // namespace
}  // namespace machplan::control
