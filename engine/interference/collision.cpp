#include "engine/interference/collision.h"

#include <fcl/narrowphase/distance.h>
#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>

#include "engine/common/error.h"

namespace machplan::interference {

struct Shape::Impl {
  Kind kind;
  std::shared_ptr<fcl::CollisionGeometryd> geometry;
  Eigen::AlignedBox3d bounds;
};

namespace {
std::shared_ptr<const Shape::Impl> make(Shape::Kind kind, std::shared_ptr<fcl::CollisionGeometryd> g,
                                        const Eigen::AlignedBox3d& b) {
  g->computeLocalAABB();
  return std::make_shared<const Shape::Impl>(Shape::Impl{kind, std::move(g), b});
}
Eigen::AlignedBox3d centred(const Eigen::Vector3d& half) { return {-half, half}; }
}  // namespace

Shape Shape::box(const Eigen::Vector3d& s) {
  MACHPLAN_ASSERT((s.array() > 0).all(), "box sizes must be positive");
  return Shape(make(Kind::box, std::make_shared<fcl::Boxd>(s.x(), s.y(), s.z()), centred(s / 2)));
}
Shape Shape::cylinder(double r, double l) {
  MACHPLAN_ASSERT(r > 0 && l > 0, "cylinder sizes must be positive");
  return Shape(make(Kind::cylinder, std::make_shared<fcl::Cylinderd>(r, l), centred({r, r, l / 2})));
}
Shape Shape::capsule(double r, double l) {
  MACHPLAN_ASSERT(r > 0 && l >= 0, "capsule sizes must be positive");
  return Shape(make(Kind::capsule, std::make_shared<fcl::Capsuled>(r, l), centred({r, r, l / 2 + r})));
}
Shape Shape::sphere(double r) {
  MACHPLAN_ASSERT(r > 0, "sphere radius must be positive");
  return Shape(make(Kind::sphere, std::make_shared<fcl::Sphered>(r), centred({r, r, r})));
}
Shape Shape::mesh(const std::vector<Eigen::Vector3d>& v, const std::vector<Eigen::Vector3i>& t) {
  MACHPLAN_ASSERT(!v.empty() && !t.empty(), "mesh needs triangles");
  auto model = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
  std::vector<fcl::Triangle> tris;
  tris.reserve(t.size());
  Eigen::AlignedBox3d b;
  for (const auto& p : v) b.extend(p);
  for (const auto& f : t) tris.emplace_back(f[0], f[1], f[2]);
  model->beginModel(static_cast<int>(t.size()), static_cast<int>(v.size()));
  model->addSubModel(v, tris);
  model->endModel();
  return Shape(make(Kind::mesh, model, b));
}

Shape Shape::copy() const {
  const fcl::CollisionGeometryd* g = impl_->geometry.get();
  std::shared_ptr<fcl::CollisionGeometryd> c;
  switch (impl_->kind) {
    case Kind::box: c = std::make_shared<fcl::Boxd>(*static_cast<const fcl::Boxd*>(g)); break;
    case Kind::cylinder: c = std::make_shared<fcl::Cylinderd>(*static_cast<const fcl::Cylinderd*>(g)); break;
    case Kind::capsule: c = std::make_shared<fcl::Capsuled>(*static_cast<const fcl::Capsuled*>(g)); break;
    case Kind::sphere: c = std::make_shared<fcl::Sphered>(*static_cast<const fcl::Sphered*>(g)); break;
    case Kind::mesh:
      c = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>(*static_cast<const fcl::BVHModel<fcl::OBBRSSd>*>(g));
      break;
  }
  return Shape(make(impl_->kind, std::move(c), impl_->bounds));
}

Shape::Kind Shape::kind() const { return impl_->kind; }
Eigen::AlignedBox3d Shape::local_bounds() const { return impl_->bounds; }

Proximity distance(const Shape& a, const Eigen::Isometry3d& Ta, const Shape& b, const Eigen::Isometry3d& Tb) {
  fcl::DistanceRequestd request;
  request.enable_nearest_points = true;
  request.enable_signed_distance = false;
  request.gjk_solver_type = fcl::GST_INDEP;
  fcl::DistanceResultd result;
  fcl::Transform3d fa(Ta.matrix()), fb(Tb.matrix());
  fcl::distance(a.impl().geometry.get(), fa, b.impl().geometry.get(), fb, request, result);
  Proximity p;
  p.distance_mm = std::max(0.0, result.min_distance);
  p.point_a_mm = result.nearest_points[0];
  p.point_b_mm = result.nearest_points[1];
  return p;
}

Eigen::Isometry3d segment_pose(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d d = p1 - p0;
  const double n = d.norm();
  if (n > 0) T.linear() = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), d / n).toRotationMatrix();
  T.translation() = (p0 + p1) / 2;
  return T;
}

double segment_distance(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& q0,
                        const Eigen::Vector3d& q1) {
  // Closest points of two segments (Ericson, Real-Time Collision Detection, 5.1.9).
  const Eigen::Vector3d d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  double s = 0, t = 0;
  constexpr double eps = 1e-12;
  if (a <= eps && e <= eps) return r.norm();
  if (a <= eps) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e <= eps) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1.dot(d2), den = a * e - b * b;
      s = den > eps ? std::clamp((b * f - c * e) / den, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1) {
        t = 1;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return ((p0 + s * d1) - (q0 + t * d2)).norm();
}

}  // namespace machplan::interference
