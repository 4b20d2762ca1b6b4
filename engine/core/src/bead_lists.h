// The neighbour stage of a step: the bead pair lists (with the beads put in cell order and cut
// into the force pass's blocks), the beads near the container, and the projectile's candidate
// beads, rebuilt only when something has moved far enough to make them stale.
#pragma once

#include <optional>

#include "dembuf/core/particles.h"
#include "simulation_state.h"

namespace dembuf::dem::detail {

/// Rebuilds what is stale: every list when a bead may have closed the skin (or after a change
/// from outside), else the projectile's candidates when it has outrun them.
void UpdateLists(const WorldParams& params, ParticleState& beads,
                 const std::optional<RigidSphere>& projectile, Simulation::Impl& s);

}  // namespace dembuf::dem::detail
