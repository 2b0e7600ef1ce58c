// Stage 2 of the DXF reader (engine/programs/internal/dxf_stages.h): every drawn entity into
// pieces of lines and arcs in mm.
#include <algorithm>
#include "engine/common/internal/numbers.h"
#include <cmath>
#include <numbers>
#include <set>
#include <string>
#include <utility>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "engine/common/error.h"
#include "engine/geometry/contour.h"
#include "engine/geometry/curve_fit.h"
#include "engine/programs/internal/dxf_stages.h"

namespace machplan::dxf {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

const std::set<std::string>& annotation_types() {
  static const std::set<std::string> t = {"TEXT", "MTEXT", "DIMENSION", "ARC_DIMENSION",
                                          "LARGE_RADIAL_DIMENSION", "LEADER", "MLEADER",
                                          "MULTILEADER", "ATTDEF", "ATTRIB", "HATCH", "POINT",
                                          "VIEWPORT", "TOLERANCE", "IMAGE", "WIPEOUT",
                                          "OLEFRAME", "OLE2FRAME", "SOLID", "TRACE", "XLINE",
                                          "RAY", "SHAPE"};
  return t;
}

bool is_supported(const std::string& type) {
  return type == "LINE" || type == "ARC" || type == "CIRCLE" || type == "LWPOLYLINE" || type == "POLYLINE" ||
         type == "SPLINE" || type == "ELLIPSE" || type == "INSERT";
}

// A 2-D affine map x -> A x + b.
struct Affine {
  Eigen::Matrix2d A = Eigen::Matrix2d::Identity();
  Vector2d b = Vector2d::Zero();
  Vector2d operator()(const Vector2d& x) const { return A * x + b; }
  Affine then(const Affine& outer) const { return {outer.A * A, outer.A * b + outer.b}; }
  // True when the map keeps circles circles: A^T A = s^2 I.
  bool similarity() const {
    const Vector2d c0 = A.col(0), c1 = A.col(1);
    const double s2 = 0.5 * (c0.squaredNorm() + c1.squaredNorm());
    return std::abs(c0.dot(c1)) <= 1e-12 * s2 && std::abs(c0.squaredNorm() - c1.squaredNorm()) <= 1e-12 * s2;
  }
};

// Halvings per curve piece when fitting arcs (the arcs of all curves together are bounded by
// DxfOptions::max_fitted_spans).
constexpr int kFitDepth = 18;
// Deepest nesting of INSERT within blocks.
constexpr int kMaxInsertDepth = 32;

// Stage 2 as one pass over the drawing, keeping what the curve fits and the tilted
// entities add up to.
class Expander {
 public:
  Expander(Drawing& d, const Scan& scan)
      : d_(d), scan_(scan), source_(d.source()), opt_(d.options()), tol_(opt_.chain_tolerance_mm),
        fit_tol_(0.5 * opt_.chain_tolerance_mm), tan_flat_(std::tan(opt_.flatten_tolerance_deg * kPi / 180)) {}

  // Every model-space entity and, through INSERT, every entity of the blocks it places.
  std::vector<Piece> run(double mm_per_unit) {
    Affine units;
    units.A *= mm_per_unit;
    // A drawing made entirely on a layout (nothing in model space) is read from the layout.
    const bool layout_only = !scan_.entities.empty() &&
                             std::all_of(scan_.entities.begin(), scan_.entities.end(), [](const Entity& e) { return e.paper_space; });
    if (layout_only)
      problem(ProfileProblem::Severity::warning, "paper_space", {},
              fmt::format("the drawing has nothing in model space; its {} paper-space entities are read as the profile",
                          scan_.entities.size()));
    for (const Entity& e : scan_.entities) {
      if (e.paper_space && !layout_only) {
        const std::size_t k = d_.new_instance(e, e.handle, e.layer);
        problem(ProfileProblem::Severity::warning, "paper_space", {k}, fmt::format("{} is on a paper-space layout; ignored", where(k)));
        continue;
      }
      entity(e, e.handle, e.layer, units, 0, {});
    }
    if (tilted_ > 0)
      problem(ProfileProblem::Severity::warning, "flattened", {},
              fmt::format("{} entit{} lie up to {:.4g} degrees off the XY plane; projected onto it (flatten tolerance "
                          "{:g} degrees)",
                          tilted_, tilted_ == 1 ? "y" : "ies", max_tilt_deg_, opt_.flatten_tolerance_deg));
    if (max_fit_deviation_ > fit_tol_)
      problem(ProfileProblem::Severity::warning, "approximation", {},
              fmt::format("a curve could only be fitted to within {:.3g} mm (asked {:g} mm)", max_fit_deviation_, fit_tol_));
    return std::move(pieces_);
  }

 private:

  // The object coordinate system of extrusion (ex, ey, ez) seen from above, as a 2-D map
  // of OCS (x, y) at OCS height z (AutoCAD's arbitrary axis algorithm). Reports and returns
  // false when the plane is tilted beyond the flatten tolerance.
  bool ocs(std::size_t k, const std::vector<Pair>& P, double z, Affine& m) {
    Vector3d n(real_of(source_, P, 210, 0.0), real_of(source_, P, 220, 0.0), real_of(source_, P, 230, 1.0));
    const double len = n.norm();
    if (!(len > 0)) {
      problem(ProfileProblem::Severity::error, "not_planar", {k}, fmt::format("{} has a zero extrusion direction", where(k)));
      return false;
    }
    n /= len;
    if (!tilt_ok(k, std::atan2(n.head<2>().norm(), std::abs(n.z())))) return false;
    const Vector3d ax = ((std::abs(n.x()) < 1.0 / 64 && std::abs(n.y()) < 1.0 / 64) ? Vector3d::UnitY().cross(n)
                                                                                      : Vector3d::UnitZ().cross(n))
                            .normalized();
    const Vector3d ay = n.cross(ax);
    m.A.col(0) = ax.head<2>();
    m.A.col(1) = ay.head<2>();
    m.b = z * n.head<2>();
    return true;
  }

  bool tilt_ok(std::size_t k, double tilt_rad) {
    if (tilt_rad <= 1e-9) return true;
    const double deg = tilt_rad * 180 / kPi;
    if (deg > opt_.flatten_tolerance_deg) {
      problem(ProfileProblem::Severity::error, "not_planar", {k},
              fmt::format("{} lies {:.4g} degrees off the XY plane, more than the flatten tolerance of {:g} "
                          "degrees: a larger one projects it onto XY",
                          where(k), deg, opt_.flatten_tolerance_deg),
              std::nullopt, "flatten_tolerance_deg");
      return false;
    }
    ++tilted_;
    max_tilt_deg_ = std::max(max_tilt_deg_, deg);
    return true;
  }

  // Points given in world coordinates must share one z, up to the tolerance plus the flatten
  // tolerance's slope over their extent.
  bool flat_ok(std::size_t k, const std::vector<Vector3d>& pts) {
    if (pts.empty()) return true;
    double zmin = pts[0].z(), zmax = zmin;
    Eigen::AlignedBox2d box;
    for (const auto& p : pts) {
      zmin = std::min(zmin, p.z());
      zmax = std::max(zmax, p.z());
      box.extend(Vector2d(p.head<2>()));
    }
    const double dz = zmax - zmin, extent = box.diagonal().norm();
    if (dz <= tol_) return true;
    const double deg = std::atan2(dz, extent) * 180 / kPi;
    if (dz <= tol_ + tan_flat_ * extent) {
      ++tilted_;
      max_tilt_deg_ = std::max(max_tilt_deg_, deg);
      return true;
    }
    problem(ProfileProblem::Severity::error, "not_planar", {k},
            fmt::format("{} spans z {:g} to {:g} ({:.4g} degrees over its extent), more than the flatten tolerance "
                        "of {:g} degrees allows: a larger one projects it onto XY",
                        where(k), zmin, zmax, deg, opt_.flatten_tolerance_deg),
            std::nullopt, "flatten_tolerance_deg");
    return false;
  }

  void entity(const Entity& e, const std::string& handle, const std::string& layer, const Affine& world, int depth,
              const std::vector<std::string>& open_blocks) {
    const std::size_t k = d_.new_instance(e, handle, layer);
    const auto E = ProfileProblem::Severity::error;
    if (!is_supported(e.type)) {
      if (annotation_types().count(e.type))
        problem(ProfileProblem::Severity::warning, "annotation_ignored", {k}, fmt::format("{} is drawing annotation; ignored", where(k)));
      else
        problem(E, "unsupported_entity", {k}, fmt::format("{} is not supported: its geometry is missing from the profile", where(k)));
      return;
    }
    const auto& P = e.pairs;
    if (e.type == "INSERT") return insert(k, e, world, depth, open_blocks);
    if (e.type == "SPLINE") return spline(k, e, world);
    if (e.type == "ELLIPSE") return ellipse(k, e, world);
    Piece local;
    Affine m;  // local -> world
    if (e.type == "LINE") {
      const Vector3d a(real_of(source_, P, 10), real_of(source_, P, 20), real_of(source_, P, 30));
      const Vector3d b(real_of(source_, P, 11), real_of(source_, P, 21), real_of(source_, P, 31));
      if (!flat_ok(k, {a, b})) return;
      local.vertices = {a.head<2>(), b.head<2>()};
      local.bulges = {0.0};
      m = world;
    } else if (e.type == "ARC" || e.type == "CIRCLE") {
      Affine o;
      if (!ocs(k, P, real_of(source_, P, 30), o)) return;
      m = o.then(world);
      const Vector2d c(real_of(source_, P, 10), real_of(source_, P, 20));
      const double r = real_of(source_, P, 40);
      double sweep = 360.0, a1 = 0.0;
      if (e.type == "ARC") {
        a1 = real_of(source_, P, 50);
        sweep = std::fmod(real_of(source_, P, 51) - a1, 360.0);
        if (sweep < 0) sweep += 360.0;
        if (sweep == 0) sweep = 360.0;  // equal angles: AutoCAD draws the full turn
      }
      if (!(r > 0) || std::abs(c.x()) + r > kMaxCoordinateMm || std::abs(c.y()) + r > kMaxCoordinateMm) {
        if (!(r <= kMaxCoordinateMm))
          throw InputError(source_, e.line, fmt::format("{}: radius {:g} is too large", where(k), r));
        problem(ProfileProblem::Severity::warning, "zero_length", {k},
                fmt::format("{} has zero length (radius {:g}); dropped", where(k), r), map_point(m, c, k));
        return;
      }
      if (sweep >= 360.0 - 1e-9) {
        local.vertices = {c + Vector2d(r, 0), c - Vector2d(r, 0)};
        local.bulges = {1.0, 1.0};
        local.closed = true;
      } else {
        const double t1 = a1 * kPi / 180, t2 = t1 + sweep * kPi / 180;
        local.vertices = {c + r * Vector2d(std::cos(t1), std::sin(t1)), c + r * Vector2d(std::cos(t2), std::sin(t2))};
        local.bulges = {std::tan(sweep * kPi / 180 / 4)};
      }
    } else if (e.type == "LWPOLYLINE") {
      Affine o;
      if (!ocs(k, P, real_of(source_, P, 38), o)) return;
      m = o.then(world);
      long declared = -1;
      for (const auto& p : P) {
        if (p.code == 90) declared = parse_int(source_, p);
        if (p.code == 10) {
          local.vertices.emplace_back(parse_real(source_, p), 0);
          local.bulges.push_back(0);
        }
        if ((p.code == 20 || p.code == 42) && local.vertices.empty())
          throw InputError(source_, p.line, fmt::format("LWPOLYLINE: group code {} before the first vertex (10)", p.code));
        if (p.code == 20) local.vertices.back().y() = parse_real(source_, p);
        if (p.code == 42) local.bulges.back() = parse_real(source_, p);
      }
      if (declared >= 0 && static_cast<std::size_t>(declared) != local.vertices.size())
        throw InputError(source_, e.line, fmt::format("LWPOLYLINE declares {} vertices (group code 90) but lists {}",
                                                      declared, local.vertices.size()));
      local.closed = (int_of(source_, P, 70) & 1) != 0;
    } else {  // POLYLINE
      const long flags = int_of(source_, P, 70);
      if (flags & (16 | 64)) {
        problem(E, "unsupported_entity", {k},
                fmt::format("{} is a polygon mesh or polyface (flags {}): a surface, not a profile", where(k), flags));
        return;
      }
      const bool three_d = (flags & 8) != 0;
      std::vector<Vector3d> pts;
      for (const auto& V : e.vertices) {
        if (int_of(source_, V, 70) & 16) continue;  // spline frame control point: not on the curve
        pts.emplace_back(real_of(source_, V, 10), real_of(source_, V, 20), real_of(source_, V, 30));
        local.bulges.push_back(three_d ? 0.0 : real_of(source_, V, 42));
      }
      if (three_d) {
        if (!flat_ok(k, pts)) return;  // world coordinates
        m = world;
      } else {
        Affine o;
        if (!ocs(k, P, real_of(source_, P, 30), o)) return;
        if (std::any_of(pts.begin(), pts.end(), [&](const Vector3d& q) { return std::abs(q.z() - pts.front().z()) > tol_; })) {
          problem(E, "not_planar", {k}, fmt::format("{} has vertices at different z", where(k)));
          return;
        }
        m = o.then(world);
      }
      for (const auto& q : pts) local.vertices.push_back(q.head<2>());
      local.closed = (flags & 1) != 0;
    }
    for (double bulge : local.bulges)
      if (!std::isfinite(bulge) || std::abs(bulge) > kMaxBulge)
        throw InputError(source_, e.line, fmt::format("{}: bulge {:g} is out of range", where(k), bulge));
    add(k, map_piece(k, local, m));
  }

  Vector2d map_point(const Affine& m, const Vector2d& p, std::size_t k) const {
    const Vector2d w = m(p);
    if (!w.allFinite() || std::abs(w.x()) > kMaxCoordinateMm || std::abs(w.y()) > kMaxCoordinateMm)
      throw InputError(source_, line_of(k), fmt::format("{}: coordinate {} mm is beyond {:g} mm", where(k), fmt_pt(w), kMaxCoordinateMm));
    return w;
  }

  // Spans the next fit may still append (one more than the limit leaves, so that an exhausted
  // fit is told apart from one that just fits).
  std::size_t fit_budget() const {
    return opt_.max_fitted_spans - std::min(fitted_spans_, opt_.max_fitted_spans) + 1;
  }

  // Keeps the worst deviation, and bounds the work: fitted spans beyond max_fitted_spans mean a
  // drawing whose curves are far too detailed for the tolerance (or absurd).
  void note_fit(const ArcFitResult& r, std::size_t k) {
    max_fit_deviation_ = std::max(max_fit_deviation_, r.max_deviation_mm);
    fitted_spans_ += r.spans;
    if (r.exhausted || fitted_spans_ > opt_.max_fitted_spans)
      throw InputError(source_, line_of(k),
                       fmt::format("{}: the drawing's curves need more than {} arcs at {:g} mm, machplan's limit; "
                                   "a coarser chain tolerance needs fewer: give one",
                                   where(k), opt_.max_fitted_spans, fit_tol_))
          .with_option("chain_tolerance_mm");
  }

  // A local piece (vertices, one bulge per vertex, open or closed) seen through m. Straight
  // spans and, under a similarity, arcs map exactly; other arcs become elliptic and are
  // fitted. The result has n - 1 bulges when open.
  Piece map_piece(std::size_t k, const Piece& local, const Affine& m) {
    Piece out;
    out.closed = local.closed;
    out.parts = {k};
    const std::size_t n = local.vertices.size();
    if (n == 0) return out;
    const bool similar = m.similarity();
    const double flip = m.A.determinant() < 0 ? -1.0 : 1.0;
    out.vertices.push_back(map_point(m, local.vertices[0], k));
    const std::size_t spans = local.closed ? n : n - 1;
    for (std::size_t i = 0; i < spans; ++i) {
      const Vector2d& a = local.vertices[i];
      const Vector2d& b = local.vertices[(i + 1) % n];
      const double bulge = local.bulges[i];
      if (bulge == 0 || similar || (b - a).norm() == 0) {
        out.bulges.push_back(flip * bulge);
        out.vertices.push_back(map_point(m, b, k));
        continue;
      }
      const Segment s = make_segment(a, b, bulge);
      for (const Vector2d& q : {Vector2d(s.center + Vector2d(s.radius, s.radius)), Vector2d(s.center - Vector2d(s.radius, s.radius))})
        map_point(m, q, k);
      auto curve = [&](double t) { return m(s.center + s.radius * Vector2d(std::cos(t), std::sin(t))); };
      note_fit(fit_arcs(curve, s.start_angle, s.start_angle + s.sweep, fit_tol_, out.vertices, out.bulges, kFitDepth, fit_budget()), k);
      out.vertices.back() = map_point(m, b, k);
    }
    if (local.closed) out.vertices.pop_back();  // the last span came back to the first vertex
    return out;
  }

  void insert(std::size_t k, const Entity& e, const Affine& world, int depth, const std::vector<std::string>& open_blocks) {
    const auto& P = e.pairs;
    std::string name;
    for (const auto& p : P)
      if (p.code == 2) name = p.value;
    const auto it = scan_.blocks.find(upper(name));
    if (it == scan_.blocks.end()) {
      problem(ProfileProblem::Severity::error, "missing_block", {k},
              fmt::format("{} places block '{}', which the drawing does not define", where(k), excerpt(name)));
      return;
    }
    const Block& blk = it->second;
    if (blk.external) {
      problem(ProfileProblem::Severity::error, "unsupported_entity", {k},
              fmt::format("{} places block '{}', an external reference to another drawing", where(k), excerpt(name)));
      return;
    }
    if (std::find(open_blocks.begin(), open_blocks.end(), it->first) != open_blocks.end())
      throw InputError(source_, e.line, fmt::format("{}: block '{}' contains itself", where(k), excerpt(name)));
    if (depth >= kMaxInsertDepth)
      throw InputError(source_, e.line, fmt::format("{}: blocks nested deeper than {}", where(k), kMaxInsertDepth));
    const double sx = real_of(source_, P, 41, 1.0), sy = real_of(source_, P, 42, 1.0);
    const double rot = real_of(source_, P, 50) * kPi / 180;
    const long cols = int_of(source_, P, 70, 1), rows = int_of(source_, P, 71, 1);
    const double dc = real_of(source_, P, 44), dr = real_of(source_, P, 45);
    if (sx == 0 || sy == 0) {
      problem(ProfileProblem::Severity::warning, "zero_length", {k}, fmt::format("{} has scale zero; dropped", where(k)));
      return;
    }
    if (cols < 1 || rows < 1 || static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows) > opt_.max_entities)
      throw InputError(source_, e.line,
                       fmt::format("{}: array of {} x {} copies is not between 1 and {}, the limit on entities: raise it",
                                   where(k), cols, rows, opt_.max_entities))
          .with_option("max_entities");
    Affine o;
    if (!ocs(k, P, real_of(source_, P, 30), o)) return;
    const Vector2d ins(real_of(source_, P, 10), real_of(source_, P, 20));
    const Eigen::Matrix2d R = Eigen::Rotation2Dd(rot).toRotationMatrix();
    std::vector<std::string> inner = open_blocks;
    inner.push_back(it->first);
    for (long r = 0; r < rows; ++r)
      for (long c = 0; c < cols; ++c) {
        Affine place;  // block coordinates -> the INSERT's OCS
        place.A = R * Eigen::DiagonalMatrix<double, 2>(sx, sy);
        place.b = ins + R * Vector2d(static_cast<double>(c) * dc, static_cast<double>(r) * dr) - place.A * blk.base;
        const Affine m = place.then(o).then(world);
        const std::string prefix = cols * rows > 1 ? fmt::format("{}[{},{}]>", label(k), c, r) : label(k) + ">";
        for (const Entity& sub : blk.entities) {
          if (sub.type == "ATTDEF") continue;  // attribute templates carry no geometry
          entity(sub, prefix + sub.handle, sub.layer == "0" ? d_.instance(k).layer : sub.layer, m, depth + 1, inner);
        }
      }
  }

  void spline(std::size_t k, const Entity& e, const Affine& world) {
    const auto& P = e.pairs;
    const long flags = int_of(source_, P, 70);
    Nurbs nurbs;
    nurbs.degree = static_cast<int>(int_of(source_, P, 71, 3));
    const std::vector<Vector3d> ctrl = points_of(source_, P, 10, "SPLINE");
    const std::vector<Vector3d> fit = points_of(source_, P, 11, "SPLINE");
    for (const auto& p : P) {
      if (p.code == 40) nurbs.knots.push_back(parse_real(source_, p));
      if (p.code == 41) nurbs.weights.push_back(parse_real(source_, p));
    }
    const long nk = int_of(source_, P, 72, -1), nc = int_of(source_, P, 73, -1), nf = int_of(source_, P, 74, -1);
    if ((nk >= 0 && static_cast<std::size_t>(nk) != nurbs.knots.size()) ||
        (nc >= 0 && static_cast<std::size_t>(nc) != ctrl.size()) || (nf >= 0 && static_cast<std::size_t>(nf) != fit.size()))
      throw InputError(source_, e.line,
                       fmt::format("SPLINE declares {} knots, {} control and {} fit points (codes 72-74) but lists {}, {} "
                                   "and {}",
                                   nk, nc, nf, nurbs.knots.size(), ctrl.size(), fit.size()));
    if (!flat_ok(k, ctrl.empty() ? fit : ctrl)) return;
    if (flags & 4) {
      if (nurbs.weights.size() != ctrl.size()) nurbs.weights.resize(ctrl.size(), 1.0);
    } else if (!nurbs.weights.empty() && nurbs.weights.size() != ctrl.size()) {
      nurbs.weights.clear();  // weights of a non-rational spline are all 1 whatever is written
    }
    Piece pc;
    pc.parts = {k};
    if (!ctrl.empty()) {
      for (const auto& q : ctrl) nurbs.control.push_back(map_point(world, q.head<2>(), k));
      try {
        nurbs.validate();
      } catch (const InputError& ex) {
        throw InputError(source_, e.line, fmt::format("{}: {}", where(k), ex.what()));
      }
      const std::vector<double> br = nurbs.breaks();
      pc.vertices.push_back(nurbs.point(br.front(), nurbs.span_of(br.front())));
      for (std::size_t i = 0; i + 1 < br.size(); ++i) {
        const std::size_t span = nurbs.span_of(0.5 * (br[i] + br[i + 1]));
        note_fit(fit_arcs([&](double t) { return nurbs.point(t, span); }, br[i], br[i + 1], fit_tol_, pc.vertices, pc.bulges, kFitDepth, fit_budget()), k);
      }
    } else {
      std::vector<Vector2d> pts;
      for (const auto& q : fit) {
        const Vector2d w = map_point(world, q.head<2>(), k);
        if (pts.empty() || (w - pts.back()).norm() > 1e-12) pts.push_back(w);
      }
      if (pts.size() < 2) {
        problem(ProfileProblem::Severity::warning, "zero_length", {k},
                fmt::format("{} has neither control points nor two distinct fit points; dropped", where(k)));
        return;
      }
      auto tangent = [&](int code) {
        const Vector2d t(real_of(source_, P, code), real_of(source_, P, code + 10));
        return Vector2d(world.A * t);
      };
      CubicInterpolant ci;
      try {
        ci = interpolate_cubic(pts, tangent(12), tangent(13));
      } catch (const InputError& ex) {
        throw InputError(source_, e.line, fmt::format("{}: {}", where(k), ex.what()));
      }
      pc.vertices.push_back(pts.front());
      for (std::size_t i = 0; i + 1 < pts.size(); ++i)
        note_fit(fit_arcs([&](double t) { return ci.point(t, i); }, ci.params[i], ci.params[i + 1], fit_tol_, pc.vertices, pc.bulges, kFitDepth, fit_budget()), k);
    }
    add(k, std::move(pc));
  }

  void ellipse(std::size_t k, const Entity& e, const Affine& world) {
    const auto& P = e.pairs;
    Vector3d n(real_of(source_, P, 210, 0.0), real_of(source_, P, 220, 0.0), real_of(source_, P, 230, 1.0));
    if (!(n.norm() > 0)) {
      problem(ProfileProblem::Severity::error, "not_planar", {k}, fmt::format("{} has a zero extrusion direction", where(k)));
      return;
    }
    n.normalize();
    if (!tilt_ok(k, std::atan2(n.head<2>().norm(), std::abs(n.z())))) return;
    const Vector3d c(real_of(source_, P, 10), real_of(source_, P, 20), real_of(source_, P, 30));
    const Vector3d major(real_of(source_, P, 11), real_of(source_, P, 21), real_of(source_, P, 31));
    // The ratio is minor over major; some writers give the longer axis as the "minor" one (a
    // ratio above 1). The curve c + cos t major + sin t minor is the same ellipse either way.
    const double ratio = real_of(source_, P, 40, 1.0);
    if (!(ratio > 0) || !(ratio <= 1e6) || !(major.norm() > 0)) {
      problem(ProfileProblem::Severity::warning, "zero_length", {k},
              fmt::format("{} has axis ratio {:g} and major axis {:g}; dropped", where(k), ratio, major.norm()));
      return;
    }
    const Vector3d minor = ratio * n.cross(major);
    for (const Vector2d& q : {Vector2d(c.head<2>() + minor.head<2>()), Vector2d(c.head<2>() - minor.head<2>())})
      map_point(world, q, k);
    double t0 = real_of(source_, P, 41, 0.0), t1 = real_of(source_, P, 42, 2 * kPi);
    double sweep = std::fmod(t1 - t0, 2 * kPi);
    if (sweep < 0) sweep += 2 * kPi;
    if (sweep < 1e-12) sweep = 2 * kPi;
    const bool full = sweep > 2 * kPi - 1e-9;
    for (const Vector2d& q : {Vector2d(c.head<2>() + major.head<2>()), Vector2d(c.head<2>() - major.head<2>())})
      map_point(world, q, k);
    auto curve = [&](double t) {
      return world(Vector2d(c.head<2>() + std::cos(t) * major.head<2>() + std::sin(t) * minor.head<2>()));
    };
    Piece pc;
    pc.parts = {k};
    pc.vertices.push_back(curve(t0));
    // Quarters at most per fit, so that no piece starts and ends at one point.
    const int parts = std::max(1, static_cast<int>(std::ceil(sweep / (kPi / 2) - 1e-9)));
    for (int i = 0; i < parts; ++i)
      note_fit(fit_arcs(curve, t0 + sweep * i / parts, t0 + sweep * (i + 1) / parts, fit_tol_, pc.vertices, pc.bulges, kFitDepth, fit_budget()), k);
    if (full && pc.vertices.size() >= 3) {
      pc.vertices.pop_back();
      pc.closed = true;
    }
    add(k, std::move(pc));
  }

  // Cleans a piece in mm (spans shorter than the tolerance merged away, a repeated first
  // vertex closing it) and keeps it, or reports why not.
  void add(std::size_t k, Piece pc) {
    const auto W = ProfileProblem::Severity::warning;
    const std::size_t n = pc.vertices.size();
    if (n == 0) return;
    const std::size_t spans = pc.closed ? n : n - 1;
    Piece c;
    c.closed = pc.closed;
    c.parts = std::move(pc.parts);
    c.vertices.push_back(pc.vertices[0]);
    int dropped = 0;
    for (std::size_t i = 0; i < spans; ++i) {
      const Vector2d& e = pc.vertices[(i + 1) % n];
      const bool near = (e - c.vertices.back()).norm() <= tol_;
      if (pc.closed && i + 1 == spans) {  // the span back to the first vertex
        if (near && c.vertices.size() > 1) {
          c.vertices.pop_back();  // the previous span now ends at the first vertex
          ++dropped;
        } else {
          c.bulges.push_back(pc.bulges[i]);
        }
        break;
      }
      if (near) {
        ++dropped;
        continue;  // zero-length span: keep the earlier vertex and its bulge
      }
      c.bulges.push_back(pc.bulges[i]);
      c.vertices.push_back(e);
    }
    if (!c.closed && c.vertices.size() >= 3 && (c.vertices.back() - c.vertices.front()).norm() <= tol_) {
      // The last vertex repeats the first: closed whatever its flag says.
      c.vertices.pop_back();
      c.closed = true;
      ++dropped;
    }
    const std::string& type = d_.instance(k).entity->type;
    if (dropped > 0 && c.vertices.size() >= 2 && (type == "LWPOLYLINE" || type == "POLYLINE"))
      problem(W, "zero_length", {k}, fmt::format("{} has {} span(s) shorter than {:g} mm; dropped", where(k), dropped, tol_));
    if (c.vertices.size() < 2 || c.length() <= tol_) {
      problem(W, "zero_length", {k}, fmt::format("{} has zero length; dropped", where(k)), c.vertices.front());
      return;
    }
    pieces_.push_back(std::move(c));
  }

  std::string where(std::size_t k) const { return d_.where(k); }
  std::string label(std::size_t k) const { return d_.label(k); }
  int line_of(std::size_t k) const { return d_.line_of(k); }
  void problem(ProfileProblem::Severity s, std::string kind, const std::vector<std::size_t>& insts, std::string message,
               std::optional<Vector2d> at = std::nullopt, std::string option = {}) {
    d_.problem(s, std::move(kind), insts, std::move(message), at, std::move(option));
  }

  Drawing& d_;
  const Scan& scan_;
  const std::string& source_;
  const DxfOptions& opt_;
  double tol_, fit_tol_, tan_flat_;
  std::vector<Piece> pieces_;
  std::size_t tilted_ = 0;
  double max_tilt_deg_ = 0.0;
  double max_fit_deviation_ = 0.0;
  std::size_t fitted_spans_ = 0;
};

}  // namespace

std::vector<Piece> expand(Drawing& d, const Scan& scan, double mm_per_unit) { return Expander(d, scan).run(mm_per_unit); }

}  // namespace machplan::dxf
