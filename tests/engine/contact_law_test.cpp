// Contact law kernels against their closed forms (docs/model.md "Contact law").
#include "engine/contact_law.h"

#include <cmath>

#include <gtest/gtest.h>

namespace granary::engine {
namespace {

TEST(ContactLaw, NormalForceIsHertzWithDamping) {
  ContactParams p;
  const double delta = 1e-3, reff = 0.25, meff = 0.4, vn = -0.3;
  const double expected = std::sqrt(reff * delta) * (p.kn * delta - meff * p.gamma_n * vn);
  EXPECT_DOUBLE_EQ(NormalForce(delta, reff, meff, vn, p), expected);
}

TEST(ContactLaw, HookeIsLinearWithDampingAndNoOverlapScale) {
  ContactParams p;
  p.normal_model = NormalModel::kHooke;
  p.mu = 1e9;  // never slips
  const double delta = 1e-3, reff = 0.25, meff = 0.4, vn = -0.3, dt = 1e-4;
  EXPECT_DOUBLE_EQ(NormalForce(delta, reff, meff, vn, p), p.kn * delta - meff * p.gamma_n * vn);
  const Tangential t = TangentialForce(0.0, 1e-5, 1.0, 0.0, 0.0, 0.2, delta, reff, meff, 10.0, dt, p);
  EXPECT_DOUBLE_EQ(t.fy, -(p.kt * (1e-5 + 0.2 * dt) + meff * p.gamma_t * 0.2));
}

TEST(ContactLaw, ClipNormalRemovesAttraction) {
  ContactParams p;
  const double delta = 1e-6, vn = 5.0;  // separating fast: damping beats the spring
  EXPECT_LT(NormalForce(delta, 0.5, 1.0, vn, p), 0.0);
  p.clip_normal = true;
  EXPECT_EQ(NormalForce(delta, 0.5, 1.0, vn, p), 0.0);
}

TEST(ContactLaw, TangentialBelowCapIsSpringPlusDamping) {
  ContactParams p;
  p.mu = 1e9;  // never slips
  const double dt = 1e-4, h = std::sqrt(0.25 * 1e-3);
  // normal along +x, tangent along y
  const Tangential t = TangentialForce(0.0, 1e-5, 1.0, 0.0, 0.0, 0.2, 1e-3, 0.25, 0.5, 10.0, dt, p);
  const double xi = 1e-5 + 0.2 * dt;
  EXPECT_DOUBLE_EQ(t.sy, xi);
  EXPECT_DOUBLE_EQ(t.sx, 0.0);
  EXPECT_NEAR(t.fy, -h * (p.kt * xi + 0.5 * p.gamma_t * 0.2), 1e-12);
}

TEST(ContactLaw, ShearIsProjectedOntoTheTangent) {
  ContactParams p;
  p.mu = 1e9;
  // stored shear has a normal component that must be removed
  const Tangential t = TangentialForce(3e-4, 4e-4, 1.0, 0.0, 0.0, 0.0, 1e-3, 0.25, 0.5, 10.0, 1e-4, p);
  EXPECT_EQ(t.sx, 0.0);
  EXPECT_DOUBLE_EQ(t.sy, 4e-4);
}

TEST(ContactLaw, LammpsCapLimitsSpringAndDampingAndRescalesHistory) {
  ContactParams p;
  p.mu = 0.3;
  const double delta = 1e-3, reff = 0.25, meff = 0.5, fn = 2.0, vt = 0.4, dt = 1e-4;
  const Tangential t = TangentialForce(0.0, 2e-3, 1.0, 0.0, 0.0, vt, delta, reff, meff, fn, dt, p);
  EXPECT_NEAR(std::hypot(t.fx, t.fy), p.mu * fn, 1e-12);
  // spring + damping with the new history give exactly the capped force
  const double h = std::sqrt(reff * delta);
  EXPECT_NEAR(-h * (p.kt * t.sy + meff * p.gamma_t * vt), t.fy, 1e-12);
}

TEST(ContactLaw, LiggghtsCapLimitsOnlyTheSpring) {
  ContactParams p;
  p.mu = 0.3;
  p.liggghts_cap = true;
  const double delta = 1e-3, reff = 0.25, meff = 0.5, fn = 2.0, dt = 1e-4;
  const double h = std::sqrt(reff * delta);
  // spring part above the cap: force = capped spring, no damping; xi = -F / (h kt)
  Tangential t = TangentialForce(0.0, 2e-3, 1.0, 0.0, 0.0, 0.4, delta, reff, meff, fn, dt, p);
  EXPECT_NEAR(t.fy, -p.mu * fn, 1e-12);
  EXPECT_NEAR(t.sy, p.mu * fn / (h * p.kt), 1e-15);
  // spring part below the cap but with damping: the total may exceed mu Fn
  const double fn2 = 100.0, xi0 = -0.0049, vt = 50.0;
  t = TangentialForce(0.0, xi0, 1.0, 0.0, 0.0, vt, delta, reff, meff, fn2, dt, p);
  const double xi = xi0 + vt * dt;
  EXPECT_LT(h * p.kt * std::fabs(xi), p.mu * fn2);
  EXPECT_NEAR(t.fy, -h * p.kt * xi - h * meff * p.gamma_t * vt, 1e-9);
  EXPECT_GT(std::fabs(t.fy), p.mu * fn2);
}

TEST(ContactLaw, HertzCollisionTimeMatchesClosedForm) {
  // m = 1, k = K_n sqrt(R) = 1, v0 = 1: delta_max = 1.25^0.4, t_c = 2.9432 delta_max
  EXPECT_NEAR(HertzCollisionTime(1.0, 1.0, 1.0, 1.0), 2.9432 * std::pow(1.25, 0.4), 1e-12);
}

}  // namespace
}  // namespace granary::engine
