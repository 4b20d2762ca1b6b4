// The scene rows of the Hertz normal force's damping (parts/hertz_normal.h): A is calibrated
// from a restitution at a reference speed (MakeContactSetup).
#include "scene/field_row.h"

namespace dembuf {

std::vector<SceneField> HertzNormalFields() {
  return {
      {"material.restitution", "", "restitution e of two mean beads meeting at the reference speed",
       Shapes::kSourceBed, DEMBUF_FIELD(material.restitution), 0.0, 1.0, true},
      {"material.restitution_ref_speed_m_s", "m/s",
       "impact speed at which e is calibrated (of every species and pair)", Shapes::kSourceBed,
       DEMBUF_FIELD(material.restitution_ref_speed_m_s), 0.0, 1000.0, true},
  };
}

}  // namespace dembuf
