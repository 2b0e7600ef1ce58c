#include "engine/geometry/curve_fit.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "engine/common/error.h"

#include "engine/geometry/contour.h"

namespace machplan {
namespace {

using Eigen::Vector2d;

// Unit tangent of the curve at t from central differences; falls back to wider steps, then
// to the chord, where the derivative vanishes (a repeated control point).
Vector2d unit_tangent(const std::function<Vector2d(double)>& c, double t, double span, const Vector2d& chord) {
  for (double h : {1e-7, 1e-5, 1e-3}) {
    const Vector2d d = c(t + h * span) - c(t - h * span);
    const double n = d.norm();
    if (n > 1e-13 * std::max(1.0, c(t).norm()) && std::isfinite(n)) return d / n;
  }
  const double n = chord.norm();
  return n > 0 ? Vector2d(chord / n) : Vector2d(1, 0);
}

// Bulge of the arc from a to b whose tangent at a (start = true) or at b is `t`.
double bulge_for(const Vector2d& a, const Vector2d& b, const Vector2d& t, bool start) {
  const Vector2d ch = b - a;
  const double half_sweep = start ? std::atan2(cross(t, ch), t.dot(ch)) : std::atan2(cross(ch, t), ch.dot(t));
  const double bulge = std::tan(half_sweep / 2);
  return std::abs(bulge) < 1e-12 ? 0.0 : bulge;
}

double deviation(const Segment& s1, const Segment& s2, const Vector2d& p) {
  return std::min((closest_point(s1, p) - p).norm(), (closest_point(s2, p) - p).norm());
}

struct Fitter {
  const std::function<Vector2d(double)>& curve;
  double tol;
  int max_depth;
  std::size_t max_spans;
  std::vector<Vector2d>& v;
  std::vector<double>& b;
  ArcFitResult result;

  void push(const Vector2d& end, double bulge) {
    const double chord = (end - v.back()).norm();
    if (chord <= 1e-12) return;
    if (!std::isfinite(bulge) || std::abs(bulge) > kMaxBulge) bulge = 0.0;
    // An arc whose sagitta (bulge * chord / 2) is a hundredth of the tolerance is a straight
    // span: keeping it as an arc of enormous radius would only cost precision downstream.
    if (std::abs(bulge) * chord / 2 <= 0.01 * tol) bulge = 0.0;
    b.push_back(bulge);
    v.push_back(end);
    ++result.spans;
  }

  void fit(double ta, double tb, const Vector2d& pa, const Vector2d& pb, int depth) {
    if (result.spans >= max_spans) {
      result.exhausted = true;
      return;
    }
    const double span = tb - ta;
    const Vector2d chord = pb - pa;
    // A closed piece (chord ~ 0) or a first pass: always split once the biarc is undefined.
    bool ok = false;
    Vector2d joint;
    double b1 = 0, b2 = 0;
    double worst = 0;
    if (chord.norm() > 1e-12) {
      const Vector2d t0 = unit_tangent(curve, ta, span, chord), t1 = unit_tangent(curve, tb, span, chord);
      const double vt = chord.dot(t0 + t1), c = t0.dot(t1);
      const double denom = vt + std::sqrt(std::max(0.0, vt * vt + 2 * (1 - c) * chord.squaredNorm()));
      if (denom > 1e-15 * chord.norm()) {
        const double d = chord.squaredNorm() / denom;
        joint = 0.5 * ((pa + d * t0) + (pb - d * t1));
        b1 = bulge_for(pa, joint, t0, true);
        b2 = bulge_for(joint, pb, t1, false);
        const Segment s1 = make_segment(pa, joint, b1), s2 = make_segment(joint, pb, b2);
        for (int k = 1; k <= kSamplesPerPiece; ++k) {
          const double t = ta + span * k / (kSamplesPerPiece + 1);
          worst = std::max(worst, deviation(s1, s2, curve(t)));
        }
        // A half turn or more per arc means the tangents disagree with the chord: refine.
        ok = worst <= tol && std::abs(b1) < 1.0 && std::abs(b2) < 1.0;
      }
    }
    if (!ok && depth < max_depth) {
      const double tm = ta + 0.5 * span;
      const Vector2d pm = curve(tm);
      fit(ta, tm, pa, pm, depth + 1);
      fit(tm, tb, pm, pb, depth + 1);
      return;
    }
    if (!ok && chord.norm() <= 1e-12) return;  // nothing measurable left
    if (!ok && (worst == 0 || !std::isfinite(worst))) {
      // No biarc exists (opposite tangents): a straight span, deviation measured.
      const Segment s = make_segment(pa, pb, 0);
      for (int k = 1; k <= kSamplesPerPiece; ++k) {
        const Vector2d p = curve(ta + span * k / (kSamplesPerPiece + 1));
        worst = std::max(worst, (closest_point(s, p) - p).norm());
      }
      result.max_deviation_mm = std::max(result.max_deviation_mm, worst);
      push(pb, 0.0);
      return;
    }
    result.max_deviation_mm = std::max(result.max_deviation_mm, worst);
    push(joint, b1);
    push(pb, b2);
  }
};

}  // namespace

ArcFitResult fit_arcs(const std::function<Vector2d(double)>& curve, double t0, double t1, double tolerance_mm,
                      std::vector<Vector2d>& vertices, std::vector<double>& bulges, int max_depth,
                      std::size_t max_spans) {
  Fitter f{curve, tolerance_mm, max_depth, max_spans, vertices, bulges, {}};
  if (vertices.empty()) vertices.push_back(curve(t0));
  const Vector2d start = vertices.back();
  const Vector2d end = curve(t1);
  f.fit(t0, t1, start, end, 0);
  // The last vertex must be c(t1) exactly, even if the last span was too short to emit.
  if ((vertices.back() - end).norm() > 0 && vertices.size() > 1 && (vertices.back() - end).norm() <= 1e-12)
    vertices.back() = end;
  return f.result;
}

// ---------------------------------------------------------------------------------------------

void Nurbs::validate() const {
  const std::size_t n = control.size();
  if (degree < 1 || degree > 30) throw InputError::field("degree", fmt::format("degree {} is outside 1..30", degree));
  const auto p = static_cast<std::size_t>(degree);
  if (n < p + 1)
    throw InputError::field("control", fmt::format("{} control points are too few for degree {}", n, degree));
  if (knots.size() != n + p + 1)
    throw InputError::field("knots", fmt::format("{} knots for {} control points of degree {}; expected {}", knots.size(),
                                                 n, degree, n + p + 1));
  for (std::size_t i = 0; i < knots.size(); ++i) {
    if (!std::isfinite(knots[i])) throw InputError::field("knots", fmt::format("knot {} is not finite", i));
    if (i > 0 && knots[i] < knots[i - 1])
      throw InputError::field("knots", fmt::format("knot {} ({:g}) is smaller than the one before ({:g})", i, knots[i],
                                                   knots[i - 1]));
  }
  if (!(knots[n] > knots[p])) throw InputError::field("knots", "the knot vector leaves an empty domain");
  if (!weights.empty()) {
    if (weights.size() != n)
      throw InputError::field("weights", fmt::format("{} weights for {} control points", weights.size(), n));
    for (std::size_t i = 0; i < n; ++i)
      if (!std::isfinite(weights[i]) || !(weights[i] > 0))
        throw InputError::field("weights", fmt::format("weight {} ({:g}) must be finite and positive", i, weights[i]));
  }
}

std::vector<double> Nurbs::breaks() const {
  const auto p = static_cast<std::size_t>(degree);
  std::vector<double> out;
  for (std::size_t i = p; i <= control.size(); ++i)
    if (out.empty() || knots[i] > out.back()) out.push_back(knots[i]);
  return out;
}

std::size_t Nurbs::span_of(double t) const {
  const auto p = static_cast<std::size_t>(degree);
  const std::size_t n = control.size();
  // Largest k in [p, n-1] with u(k) <= t and u(k) < u(k+1).
  auto it = std::upper_bound(knots.begin() + static_cast<long>(p), knots.begin() + static_cast<long>(n), t);
  std::size_t k = static_cast<std::size_t>(it - knots.begin());
  k = k == p ? p : k - 1;
  while (k > p && !(knots[k] < knots[k + 1])) --k;
  while (k + 1 < n && !(knots[k] < knots[k + 1])) ++k;
  return k;
}

Vector2d Nurbs::point(double t, std::size_t k) const {
  const auto p = static_cast<std::size_t>(degree);
  Eigen::Vector3d d[31];
  for (std::size_t j = 0; j <= p; ++j) {
    const std::size_t i = j + k - p;
    const double w = weights.empty() ? 1.0 : weights[i];
    d[j] = Eigen::Vector3d(control[i].x() * w, control[i].y() * w, w);
  }
  for (std::size_t r = 1; r <= p; ++r)
    for (std::size_t j = p; j >= r; --j) {
      const double lo = knots[j + k - p], hi = knots[j + 1 + k - r];
      const double alpha = (t - lo) / (hi - lo);
      d[j] = (1 - alpha) * d[j - 1] + alpha * d[j];
    }
  return d[p].head<2>() / d[p].z();
}

Vector2d CubicInterpolant::point(double t, std::size_t i) const {
  const double h = params[i + 1] - params[i];
  const double u = (t - params[i]) / h;
  const double u2 = u * u, u3 = u2 * u;
  return (2 * u3 - 3 * u2 + 1) * points[i] + (u3 - 2 * u2 + u) * h * derivatives[i] +
         (-2 * u3 + 3 * u2) * points[i + 1] + (u3 - u2) * h * derivatives[i + 1];
}

CubicInterpolant interpolate_cubic(const std::vector<Vector2d>& pts, const Vector2d& start_tangent,
                                   const Vector2d& end_tangent) {
  const std::size_t n = pts.size();
  if (n < 2) throw InputError::field("points", fmt::format("{} point(s): a curve through points needs at least 2", n));
  CubicInterpolant out;
  out.points = pts;
  out.params.assign(n, 0.0);
  std::vector<double> h(n - 1);
  for (std::size_t i = 0; i + 1 < n; ++i) {
    h[i] = (pts[i + 1] - pts[i]).norm();
    if (!(h[i] > 0) || !std::isfinite(h[i]))
      throw InputError::field("points", fmt::format("points {} and {} coincide", i, i + 1));
    out.params[i + 1] = out.params[i] + h[i];
  }
  // Tridiagonal system a m(i-1) + b m(i) + c m(i+1) = r(i) for the derivatives (C2 cubic).
  std::vector<double> a(n, 0), b(n, 0), c(n, 0);
  std::vector<Vector2d> r(n, Vector2d::Zero());
  auto delta = [&](std::size_t i) -> Vector2d { return (pts[i + 1] - pts[i]) / h[i]; };
  if (start_tangent.norm() > 0) {
    b[0] = 1;
    r[0] = start_tangent.normalized();
  } else {
    b[0] = 2;
    c[0] = 1;
    r[0] = 3 * delta(0);
  }
  for (std::size_t i = 1; i + 1 < n; ++i) {
    a[i] = h[i];
    b[i] = 2 * (h[i - 1] + h[i]);
    c[i] = h[i - 1];
    r[i] = 3 * (h[i] * delta(i - 1) + h[i - 1] * delta(i));
  }
  if (end_tangent.norm() > 0) {
    a[n - 1] = 0;
    b[n - 1] = 1;
    r[n - 1] = end_tangent.normalized();
  } else {
    a[n - 1] = 1;
    b[n - 1] = 2;
    r[n - 1] = 3 * delta(n - 2);
  }
  // Thomas algorithm: the matrix is diagonally dominant, no pivoting needed.
  for (std::size_t i = 1; i < n; ++i) {
    const double m = a[i] / b[i - 1];
    b[i] -= m * c[i - 1];
    r[i] -= m * r[i - 1];
  }
  out.derivatives.assign(n, Vector2d::Zero());
  out.derivatives[n - 1] = r[n - 1] / b[n - 1];
  for (std::size_t i = n - 1; i-- > 0;) out.derivatives[i] = (r[i] - c[i] * out.derivatives[i + 1]) / b[i];
  return out;
}

}  // namespace machplan
