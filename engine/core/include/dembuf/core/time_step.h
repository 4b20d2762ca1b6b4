// Critical time step of the paper's eq. 6 (the Rayleigh-wave time of the smallest bead).
#pragma once

#include <cmath>
#include <numbers>

namespace dembuf::dem {

/// tmax = pi Rmin / (0.163 nu + 0.8766) * sqrt(rho / G).
inline double CriticalTimeStep(double min_radius_m, double density_kg_m3, double youngs_modulus_Pa,
                               double poisson_ratio) {
  double shear_modulus = youngs_modulus_Pa / (2.0 * (1.0 + poisson_ratio));
  return std::numbers::pi * min_radius_m / (0.163 * poisson_ratio + 0.8766) *
         std::sqrt(density_kg_m3 / shear_modulus);
}

}  // namespace dembuf::dem
