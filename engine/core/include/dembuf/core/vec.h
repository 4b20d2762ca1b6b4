// Small vector math: Eigen's fixed-size vectors, cheap in per-pair code.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products

namespace dembuf::dem {
using Vec3 = Eigen::Vector3d;
}  // namespace dembuf::dem
