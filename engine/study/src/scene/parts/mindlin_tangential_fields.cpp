// The scene rows of friction (parts/mindlin_tangential.h). The bead pairs' friction is changed
// after settling when it differs from bed.prep_friction (the friction stage of a bed).
#include "scene/field_row.h"

namespace dembuf {

std::vector<SceneField> MindlinTangentialFields() {
  return {
      {"material.friction_bead_bead", "",
       "mu_pp of species 1: its beads together, the projectile on them (on species k: "
       "pairs.friction_1_k)",
       Shapes::kFrictionBed, DEMBUF_FIELD(material.friction_bead_bead), 0.0, 10.0},
      {"material.friction_bead_wall", "", "mu_pw, friction with plate and wall (beads, projectile)",
       Shapes::kSourceBed, DEMBUF_FIELD(material.friction_bead_wall), 0.0, 10.0},
  };
}

}  // namespace dembuf
