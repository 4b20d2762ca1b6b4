// The scene's side of the physics parts (engine/core/include/dembuf/core/parts/): each has one
// file under src/scene/parts/ with its rows of the field table (which scene_fields.cpp takes,
// in its order, through src/scene/field_row.h) and, where a part has parameters of its own in
// the world, the function that sets them from a scene, declared here.
#pragma once

#include "dembuf/core/simulation.h"
#include "dembuf/study/scene/scene.h"

namespace dembuf {

/// RollingResistance: mu_r (MakeContactSetup).
void SetRollingResistance(const Scene& scene, dem::WorldParams& world);

/// LocalViscousDamping: the beads' own damping, in the impact's world only.
void SetBeadDamping(const Scene& scene, dem::WorldParams& world);

}  // namespace dembuf
