// How a row of the field table names its Scene member, and the physics parts' rows (one file
// each under src/scene/parts/), which scene_fields.cpp puts in the table in its order.
#pragma once

#include <vector>

#include "dembuf/study/scene/scene_fields.h"

/// A captureless lambda returning a reference to one Scene member, as a function pointer.
#define DEMBUF_FIELD(member) +[](Scene& s) -> decltype(auto) { return (s.member); }

namespace dembuf {

/// HertzNormal: the restitution its damping A is calibrated from (MakeContactSetup).
std::vector<SceneField> HertzNormalFields();

/// MindlinTangential: the friction of bead pairs and of beads with the walls.
std::vector<SceneField> MindlinTangentialFields();

/// RollingResistance: mu_r.
std::vector<SceneField> RollingResistanceFields();

/// SpeciesPairs: the second and third species, their pairs' rules, and the layers that mix
/// them (species_pairs_fields.cpp).
std::vector<SceneField> SpeciesPairsFields();

/// LocalViscousDamping: the beads' own damping.
std::vector<SceneField> BeadDampingFields();

}  // namespace dembuf
