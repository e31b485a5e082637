// SPDX-License-Identifier: GPL-3.0-or-later
#include "oblate.h"

#include <units.h>

#include <cmath>
#include <stdexcept>

namespace hemo::particles {

namespace {

// Below this 1 - lambda the closed forms lose digits to cancellation (~1e-18 / eps^2); the
// two-term series about the sphere is then exact to ~eps^3 < 1e-12.
constexpr double kSeriesBelow = 1e-4;

void check_lambda(double lambda) {
  if (!(lambda > 0 && lambda <= 1)) throw std::invalid_argument("oblate: the aspect ratio c/a must be in (0, 1]");
}

void check(const ClosureParams& p) {
  if (!(p.viscosity > 0) || !(p.diameter > 0) || !(p.fluid_density > 0))
    throw std::invalid_argument("oblate closures need a positive viscosity, density and diameter");
  if (!(p.aspect_ratio > 0 && p.aspect_ratio < 1))
    throw std::invalid_argument("oblate closures need an aspect ratio c/a in (0, 1)");
}

// n.e and the slip's norm; false when there is no slip.
bool incidence(const ParticleFlow& f, double* cos_phi, double* speed) {
  *speed = f.slip.norm();
  if (!(*speed > 0)) return false;
  *cos_phi = f.axis.dot(f.slip) / *speed;
  return true;
}

}  // namespace

double oblate_k0(double lambda) {
  check_lambda(lambda);
  const double eps = 1 - lambda;
  if (eps < kSeriesBelow) return 1 + eps * (2.0 / 15 + eps * 263.0 / 1575);
  const double s = std::sqrt(1 - lambda * lambda);
  return 4.0 / 3 * std::cbrt(1 / lambda) * (1 - lambda * lambda) /
         (lambda + (1 - 2 * lambda * lambda) / s * std::acos(lambda));
}

double oblate_k90(double lambda) {
  check_lambda(lambda);
  const double eps = 1 - lambda;
  if (eps < kSeriesBelow) return 1 + eps * (-1.0 / 15 + eps * 199.0 / 3150);
  const double s = std::sqrt(1 - lambda * lambda);
  return 8.0 / 3 * std::cbrt(1 / lambda) * (lambda * lambda - 1) /
         (lambda - (3 - 2 * lambda * lambda) / s * std::acos(lambda));
}

OblateDrag::OblateDrag(const ClosureParams& p) : params_(p) {
  check(p);
  const double l = p.aspect_ratio;
  stokes_ = 3 * units::pi * p.viscosity * p.diameter;
  k0_ = oblate_k0(l);
  k90_ = oblate_k90(l);
  c0_a_ = 0.15 * std::pow(l, 95.91);
  c0_b_ = 0.2927 * std::pow(1 - l, 0.4374);
  c90_a_ = 0.15 * std::pow(l, 100.7);
  c90_b_ = 0.1411 * (1 - std::pow(l, 24.75));
  // lambda^96 and lambda^101 are ~1e-59 for a platelet: for any Re below 1e10 such a term is
  // less than half an ulp of K and adding it changes no bit, so it is not computed.
  for (double* c : {&c0_a_, &c90_a_})
    if (*c < 1e-30) *c = 0;
}

double OblateDrag::f0(double re) const {
  return k0_ + (c0_a_ != 0 ? c0_a_ * std::pow(re, 0.687) : 0.0) + c0_b_ * std::pow(re, 0.7512);
}
double OblateDrag::f90(double re) const {
  return k90_ + (c90_a_ != 0 ? c90_a_ * std::pow(re, 0.687) : 0.0) + c90_b_ * std::pow(re, 0.7143);
}

double OblateDrag::coefficient(const ParticleFlow& flow) const {
  double c = 0, speed = 0;
  if (!incidence(flow, &c, &speed)) return stokes_ * k0_;  // any orientation: no force at zero slip
  const double re = params_.reynolds(flow.slip);
  const double c2 = std::min(1.0, c * c);
  return stokes_ * (f0(re) * c2 + f90(re) * (1 - c2));
}

OblateLift::OblateLift(const ClosureParams& p) : params_(p), drag_(p) {
  const double l = p.aspect_ratio;
  shape_ = 2 * std::pow((1 - l) / l, 0.542) / std::pow(1 + l, 7.85);
}

Vec3 OblateLift::force(const ParticleFlow& flow) const {
  double c = 0, speed = 0;
  if (!incidence(flow, &c, &speed)) return Vec3::Zero();
  const Vec3 e = flow.slip / speed;
  const double re = params_.reynolds(flow.slip);
  const double area = units::pi / 4 * params_.diameter * params_.diameter;
  // C_L' 1/2 rho |u_r|^2 A with the (C_D,0 - C_D,90) part's 1/Re cancelled.
  const double stokes = 3 * units::pi * params_.viscosity * params_.diameter;
  const double magnitude = stokes * speed * (drag_.f0(re) - drag_.f90(re)) +
                           shape_ * std::pow(re, 0.1516) * 0.5 * params_.fluid_density * speed * speed * area;
  return magnitude * c * (flow.axis - c * e);
}

OblateTorque::OblateTorque(const ClosureParams& p) : params_(p) {
  check(p);
  const double l = p.aspect_ratio, d = p.diameter;
  scale_ = 1.85 * std::pow((1 - l) / l, 0.832) * 0.5 * p.fluid_density * units::pi / 8 * d * d * d;
}

Vec3 OblateTorque::torque(const ParticleFlow& flow) const {
  double c = 0, speed = 0;
  if (!incidence(flow, &c, &speed)) return Vec3::Zero();
  const double re = params_.reynolds(flow.slip);
  if (!(re > 0)) return Vec3::Zero();  // a slip so small that Re underflows
  // C_T' |u_r|^2 (n.e)(n x e) = C_T' (n.e) |u_r| (n x u_r)
  return scale_ * std::pow(re, -0.146) * c * speed * flow.axis.cross(flow.slip);
}

}  // namespace hemo::particles
