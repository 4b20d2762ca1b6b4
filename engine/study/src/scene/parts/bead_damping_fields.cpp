// The scene rows of the beads' own damping (parts/bead_damping.h), and its world parameters:
// the impact's only (a bed is prepared, and shared, without it).
#include "dembuf/study/scene/part_fields.h"
#include "scene/field_row.h"

namespace dembuf {

std::vector<SceneField> BeadDampingFields() {
  return {
      {"damping.local_alpha", "",
       "local damping of every bead's motion in the impact: a force -alpha |F| sign(v) per degree "
       "of freedom (as PFC's); 0 = none, as the paper states its model",
       Shapes::kImpact, DEMBUF_FIELD(bead_damping.local_alpha), 0.0, 1.0, false, true},
      {"damping.viscous_rate_per_s", "1/s",
       "viscous background damping of every bead's motion in the impact: -rate m v and -rate I w; "
       "0 = none",
       Shapes::kImpact, DEMBUF_FIELD(bead_damping.viscous_rate_per_s), 0.0, 1e5},
  };
}

void SetBeadDamping(const Scene& scene, dem::WorldParams& world) {
  world.bead_damping = {scene.bead_damping.local_alpha, scene.bead_damping.viscous_rate_per_s};
}

}  // namespace dembuf
