// The force stage of a step: every contact's force and torque from the current state, with
// the plate and wall loads and what went wrong (an overlap too deep). Bead pairs go in
// vectorized batches over the blocks of block_schedule.h, the beads near the plate and the side
// wall likewise, then the projectile on its own.
#pragma once

#include <optional>

#include "dembuf/core/particles.h"
#include "simulation_state.h"

namespace dembuf::dem::detail {

/// Computes the forces and torques of all bodies (overwriting the last ones), the step's
/// observables, and s.conditions. Results do not depend on the thread count.
/// `forces_cleared`: the beads' forces and torques are zero already (KickAndDriftBeads).
void ComputeForcePass(const WorldParams& params, ParticleState& beads,
                      std::optional<RigidSphere>& projectile, Simulation::Impl& s,
                      StepObservables& obs, bool forces_cleared);

}  // namespace dembuf::dem::detail
