// What a scene says of its contacts and its flight, before any body exists: the contact
// constants with the calibrated damping, the time step, and the projectile's free fall.
#pragma once

#include "dembuf/core/damping.h"
#include "dembuf/core/simulation.h"
#include "dembuf/study/scene/scene.h"

namespace dembuf {

/// The contact constants, container, gravity and time step of a scene (no bodies yet).
struct ContactSetup {
  dem::WorldParams params;
  dem::DampingCalibration contact_damping;
  double critical_dt_s = 0.0;  ///< eq. 6 for the smallest bead (of the quickest species)
};

/// Derives the contact setup for beads whose smallest radius is min_radius_m (of any species:
/// eq. 6 is taken for each species in the bed at that radius). A bed of several species gets
/// the table of its pairs (dem::SpeciesTable).
ContactSetup MakeContactSetup(const Scene& scene, double min_radius_m);

/// Eq. 6's critical step of a scene's beads at radius min_radius_m: of the quickest species in
/// the bed (MakeContactSetup's, without calibrating anything).
double CriticalTimeStepOf(const Scene& scene, double min_radius_m);

/// Free flight under gravity: time until the projectile's centre, starting at height z0 with
/// vertical velocity vz0 (positive up), comes down to height z1 < z0. Returns -1 if never.
double FallTime(double z0, double vz0, double z1, double gravity_m_s2);

}  // namespace dembuf
