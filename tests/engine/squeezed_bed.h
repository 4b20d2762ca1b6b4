// A bed file for the import tests: three layers of beads on a square lattice squeezed tighter
// than touching, resting on the plate of a cylinder.
#pragma once

#include <cmath>
#include <sstream>
#include <string>

namespace dembuf::test {

/// Three layers of beads of diameter `d` on a square lattice `squeeze` (a fraction of d)
/// tighter than touching, the beads whose centres lie within `radius` - d of the axis; the
/// text of a bed file, one bead a line. `count` gets the number of beads.
inline std::string SqueezedLayers(double squeeze, double radius, int* count = nullptr,
                                  double d = 0.004) {
  const double spacing = (1.0 - squeeze) * d;
  const int n = static_cast<int>(std::ceil(radius / spacing));
  std::ostringstream out;
  out.precision(17);
  int beads = 0;
  for (int layer = 0; layer < 3; ++layer)
    for (int i = -n; i <= n; ++i)
      for (int j = -n; j <= n; ++j) {
        const double x = spacing * i, y = spacing * j;
        if (std::hypot(x, y) > radius - d) continue;
        out << x << " " << y << " " << 0.5 * d + spacing * layer << " " << 0.5 * d << "\n";
        ++beads;
      }
  if (count) *count = beads;
  return out.str();
}

}  // namespace dembuf::test
