// Calibration of the damping constant A from a restitution coefficient (docs/model.md section 2).
//
// For the law m* x'' = -Kn x^(3/2) - A Kn x^(1/2) x' the scalings x = L X, t = (L/v) T with
// L = (m* v^2 / Kn)^(2/5) turn every head-on collision into
//
//   X'' = -X^(3/2) - g X^(1/2) X',   X(0) = 0, X'(0) = 1,   g = A (Kn/m*)^(2/5) v^(1/5),
//
// so the restitution coefficient is a function e(g) of one number. Calibration integrates that
// collision and root-finds g for the requested e; A then follows for the reference pair and
// speed. The same A serves every pair of one material (each kind of pair of several species has
// its own), so e falls slowly with impact speed (e(v) via g ~ v^(1/5)).
#pragma once

#include <vector>

namespace dembuf::dem {

/// Restitution of the dimensionless collision above (RK4, fine step; the force is clamped at 0).
double RestitutionOfDampingNumber(double g);

/// The g >= 0 with RestitutionOfDampingNumber(g) = e, for e in (0, 1].
double DampingNumberForRestitution(double e);

/// e of a head-on collision of a pair (normal stiffness kn, reduced mass m*) at speed v.
double RestitutionAtSpeed(double damping_A_s, double kn, double reduced_mass_kg, double speed_m_s);

struct RestitutionPoint {
  double speed_m_s;
  double restitution;
};

/// The calibration and a few points of e(v) for the reference pair, for reports.
struct DampingCalibration {
  double damping_A_s = 0.0;
  double target_restitution = 1.0;
  double ref_speed_m_s = 1.0;
  double restitution_at_ref = 1.0;  ///< e recomputed at v_ref with the calibrated A
  std::vector<RestitutionPoint> restitution_curve;
};

/// Calibrates A so that the reference pair (stiffness kn, reduced mass m*) meeting head-on at
/// ref_speed rebounds with `restitution`.
DampingCalibration CalibrateDamping(double restitution, double ref_speed_m_s, double kn,
                                    double reduced_mass_kg);

}  // namespace dembuf::dem
