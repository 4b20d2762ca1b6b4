#include "dembuf/core/damping.h"

#include <cmath>
#include <mutex>
#include <stdexcept>
#include <unordered_map>

namespace dembuf::dem {
namespace {

// Dimensionless acceleration of the collision; the force never pulls (clamp at 0).
double Acceleration(double x, double v, double g) {
  if (x <= 0.0) return 0.0;
  double f = std::sqrt(x) * (x + g * v);
  return f > 0.0 ? -f : 0.0;
}

// The restitution of one collision with damping number g.
double IntegrateCollision(double g) {
  // The undamped contact lasts 3.22 time units; 2e4 RK4 steps per unit resolve the start of
  // the contact, where x^(1/2) is not smooth, to about 1e-7 in e.
  constexpr double kStep = 5e-5;
  constexpr long kMaxSteps = 200'000'000;
  double x = 0.0, v = 1.0;
  for (long i = 0; i < kMaxSteps; ++i) {
    const double h = kStep;
    double k1x = v, k1v = Acceleration(x, v, g);
    double k2x = v + 0.5 * h * k1v, k2v = Acceleration(x + 0.5 * h * k1x, k2x, g);
    double k3x = v + 0.5 * h * k2v, k3v = Acceleration(x + 0.5 * h * k2x, k3x, g);
    double k4x = v + h * k3v, k4v = Acceleration(x + h * k3x, k4x, g);
    double x_next = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
    double v_next = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
    if (x_next <= 0.0 && v_next < 0.0) return -v_next;  // separated
    x = x_next;
    v = v_next;
    // Once the force has vanished while receding it stays zero: the speed is final.
    if (v < 0.0 && Acceleration(x, v, g) == 0.0) return -v;
  }
  return 0.0;  // still in contact after 1e4 time units: a fully plastic collision
}

}  // namespace

double RestitutionOfDampingNumber(double g) {
  // Remembered: a calibration integrates the collision some fifty times (the bisection of
  // DampingNumberForRestitution, then e(v)), 50 ms, 40% of a bare-plate run, and every bed
  // stage and run of a sweep calibrates the same pairs again. Bounded, for a process that
  // meets many.
  static std::mutex mutex;
  static std::unordered_map<double, double> known;
  constexpr std::size_t kMaxKnown = 100'000;
  {
    std::lock_guard lock(mutex);
    if (const auto it = known.find(g); it != known.end()) return it->second;
  }
  const double e = IntegrateCollision(g);
  std::lock_guard lock(mutex);
  if (known.size() >= kMaxKnown) known.clear();
  if (!std::isnan(g)) known.emplace(g, e);
  return e;
}

double DampingNumberForRestitution(double e) {
  if (!(e > 0.0 && e <= 1.0)) throw std::invalid_argument("restitution must be in (0, 1]");
  if (e == 1.0) return 0.0;
  double lo = 0.0, hi = 0.1;
  while (RestitutionOfDampingNumber(hi) > e) {
    lo = hi;
    hi *= 2.0;
    if (hi > 1e6) throw std::invalid_argument("restitution too small to calibrate");
  }
  // e(g) is smooth and decreasing: bisection to a relative width of 1e-12.
  while (hi - lo > 1e-12 * hi) {
    double mid = 0.5 * (lo + hi);
    (RestitutionOfDampingNumber(mid) > e ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

namespace {
double DampingNumber(double damping_A_s, double kn, double reduced_mass_kg, double speed_m_s) {
  return damping_A_s * std::pow(kn / reduced_mass_kg, 0.4) * std::pow(speed_m_s, 0.2);
}
}  // namespace

double RestitutionAtSpeed(double damping_A_s, double kn, double reduced_mass_kg, double speed_m_s) {
  return RestitutionOfDampingNumber(DampingNumber(damping_A_s, kn, reduced_mass_kg, speed_m_s));
}

DampingCalibration CalibrateDamping(double restitution, double ref_speed_m_s, double kn,
                                    double reduced_mass_kg) {
  DampingCalibration cal;
  cal.target_restitution = restitution;
  cal.ref_speed_m_s = ref_speed_m_s;
  double g = DampingNumberForRestitution(restitution);
  cal.damping_A_s = g / DampingNumber(1.0, kn, reduced_mass_kg, ref_speed_m_s);
  cal.restitution_at_ref = RestitutionAtSpeed(cal.damping_A_s, kn, reduced_mass_kg, ref_speed_m_s);
  for (double factor : {0.1, 0.3, 1.0, 3.0, 10.0}) {
    double v = factor * ref_speed_m_s;
    cal.restitution_curve.push_back(
        {v, RestitutionAtSpeed(cal.damping_A_s, kn, reduced_mass_kg, v)});
  }
  return cal;
}

}  // namespace dembuf::dem
