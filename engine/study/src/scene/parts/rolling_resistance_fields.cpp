// The scene rows of rolling resistance (parts/rolling_resistance.h), and its world parameter.
#include "dembuf/study/scene/part_fields.h"
#include "scene/field_row.h"

namespace dembuf {

std::vector<SceneField> RollingResistanceFields() {
  return {
      {"material.rolling_friction", "",
       "mu_r, rolling resistance of every contact in the impact (0 = none, as the paper)",
       Shapes::kImpact, DEMBUF_FIELD(material.rolling_friction), 0.0, 1.0},
  };
}

void SetRollingResistance(const Scene& scene, dem::WorldParams& world) {
  world.rolling_friction = scene.material.rolling_friction;
}

}  // namespace dembuf
