// The small scene the engine tests share: a bed that settles in seconds.
#pragma once

#include "dembuf/study/scene/scene.h"

namespace dembuf::test {

/// A 2 cm cylinder, a 1.5 cm source bed cut to 1 cm, hit at 2 m/s by a 1.2 cm, 10 g sphere
/// released 2 cm above the surface: friction, rotation, damping, plate and wall all act.
inline Scene SmallBedScene() {
  Scene s;
  s.cylinder.radius_m = 0.02;
  s.bed.thickness_m = 0.01;
  s.bed.source_thickness_m = 0.015;
  s.projectile.diameter_m = 0.012;
  s.projectile.mass_kg = 0.01;
  s.projectile.speed_m_s = 2.0;
  s.projectile.height_m = 0.02;
  // Settled at the true stiffness throughout: the beds the tests measure other things on,
  // and the reference the soft settling test compares with.
  s.bed.soft_settling = 1.0;
  return s;
}

}  // namespace dembuf::test
