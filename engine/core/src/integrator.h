// Velocity Verlet for the beads and the projectile: half kicks (v += dt/2 a, w += dt/2 alpha)
// and the drift (x += dt v). A step leaves the beads' closing half kick pending and the next
// step fuses it with its opening one, so that each step reads the beads once here.
#pragma once

#include "dembuf/core/particles.h"
#include "simulation_state.h"

namespace dembuf::dem::detail {

/// What the drift saw: the largest displacement of a bead since the lists were built, and a
/// bead that went wrong (-1: none): non-finite, or outside the container.
struct DriftReport {
  double max_displacement = 0.0;
  long nonfinite_bead = -1;
  long escaped_bead = -1;
};

/// The opening half kick of every bead (after the last step's closing one when `closing`) and
/// the drift, in one pass shared by the threads as the force pass shares it. The beads' forces
/// and torques are zero afterwards, ready for ComputeForcePass(..., forces_cleared = true).
DriftReport KickAndDriftBeads(const WorldParams& params, bool closing, ParticleState& beads,
                              Simulation::Impl& s);

/// One half kick of every bead with its current forces (the pending closing one).
void HalfKickBeads(const WorldParams& params, ParticleState& beads, const Simulation::Impl& s);

/// One half kick of the projectile; `rotate`: its torque turns it.
void HalfKickProjectile(const WorldParams& params, bool rotate, RigidSphere& projectile);

}  // namespace dembuf::dem::detail
