// Bead state as structure of arrays (one contiguous array per property), and the rigid bodies.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <vector>

#include "dembuf/core/parts/species_pairs.h"
#include "dembuf/core/vec.h"

namespace dembuf::dem {

/// Who a contact joins: beads are numbered 0 .. n - 1, and the plate, the side wall and the
/// projectile have the top ids. One encoding for contact histories, snapshots and the kernels.
using BodyId = std::uint32_t;
inline constexpr BodyId kPlate = 0xFFFFFFFF;
inline constexpr BodyId kSideWall = 0xFFFFFFFE;
inline constexpr BodyId kProjectile = 0xFFFFFFFD;
/// True for a bead's id.
inline constexpr bool IsBead(BodyId id) {
  return id < kProjectile;
}

/// All beads. Indices are bead ids; every array has size().
struct ParticleState {
  std::vector<Vec3> position;
  std::vector<Vec3> velocity;
  std::vector<Vec3> angular_velocity;
  std::vector<Vec3> force;   ///< contact force of the current step (gravity apart)
  std::vector<Vec3> torque;  ///< contact torque of the current step
  std::vector<double> radius;
  std::vector<double> mass;
  /// 0 holds a bead in place: it neither moves nor turns, its mass still enters its contacts
  /// with free beads, and two held beads do not touch (their contact could move nothing).
  std::vector<double> inv_mass;
  /// Which of the world's species each bead is (WorldParams::species); all 0 for one species.
  std::vector<Species> species;
  /// The bed layer each bead was poured in (0 for a bed of one layer): carried with the bead
  /// wherever it goes, never read by the steps.
  std::vector<std::uint8_t> layer;

  std::size_t size() const { return position.size(); }

  /// 1 / I of bead i, a solid sphere: I = 2/5 m r^2. Computed, not stored (8 bytes a bead).
  double InvInertia(std::size_t i) const { return InverseSphereInertia(mass[i], radius[i]); }
  static double InverseSphereInertia(double m, double r) { return 1.0 / (0.4 * m * r * r); }

  /// Appends a bead at rest.
  void Add(const Vec3& x, double r, double density_kg_m3, Species kind = 0,
           std::uint8_t in_layer = 0) {
    double m = density_kg_m3 * 4.0 / 3.0 * std::numbers::pi * r * r * r;
    position.push_back(x);
    velocity.push_back(Vec3::Zero());
    angular_velocity.push_back(Vec3::Zero());
    force.push_back(Vec3::Zero());
    torque.push_back(Vec3::Zero());
    radius.push_back(r);
    mass.push_back(m);
    inv_mass.push_back(1.0 / m);
    species.push_back(kind);
    layer.push_back(in_layer);
  }

  /// Appends bead i of `from` with every property as it is.
  void AddCopy(const ParticleState& from, std::size_t i) {
    position.push_back(from.position[i]);
    velocity.push_back(from.velocity[i]);
    angular_velocity.push_back(from.angular_velocity[i]);
    force.push_back(from.force[i]);
    torque.push_back(from.torque[i]);
    radius.push_back(from.radius[i]);
    mass.push_back(from.mass[i]);
    inv_mass.push_back(from.inv_mass[i]);
    species.push_back(from.species[i]);
    layer.push_back(from.layer[i]);
  }

  /// Kinetic energy of bead i, translation and rotation [J].
  double KineticEnergy(std::size_t i) const {
    return 0.5 * mass[i] * velocity[i].squaredNorm() +
           0.5 / InvInertia(i) * angular_velocity[i].squaredNorm();
  }
};

/// A rigid sphere with its own mass (the projectile).
struct RigidSphere {
  Vec3 position = Vec3::Zero();
  Vec3 velocity = Vec3::Zero();
  Vec3 angular_velocity = Vec3::Zero();
  Vec3 force = Vec3::Zero();
  Vec3 torque = Vec3::Zero();
  double radius = 0.0;
  double mass = 0.0;

  double Inertia() const { return 0.4 * mass * radius * radius; }
};

/// The container: bottom plate at z = 0 and a cylindrical side wall around the z axis, of
/// height `height`. A sphere whose centre is at 0 <= z <= height meets the wall's face; one
/// whose centre is above it can meet only the wall's top edge, the rim. Its geometry is written
/// here once, in components and without branches (& rather than &&, selects), so that the
/// vectorized contact batches use it too.
struct Container {
  double radius_m = 0.0;
  double height_m = 0.0;

  /// Overlap of a sphere of radius r whose centre is at height z with the plate (> 0: touching).
  static double PlateOverlap(double z, double r) { return r - z; }

  /// Whether a sphere (centre x, y, z, radius r) touches the side wall: its centre is farther
  /// from the axis than radius - r, at a height where the wall's face acts; or it reaches the
  /// rim from above (the rim's distance, a square root, is taken only for centres above it).
  bool TouchesSideWall(double x, double y, double z, double r) const {
    const double inner = radius_m - r;
    const double rho2 = x * x + y * y;
    const bool face = (rho2 > inner * inner) & (z >= 0.0) & (z <= height_m);
    return face || ((z > height_m) && RimOverlap(std::sqrt(rho2), z, r) > 0.0);
  }

  /// Overlap with the side wall's face of a sphere of radius r whose centre is `rho` from the
  /// axis.
  double SideWallOverlap(double rho, double r) const { return rho - (radius_m - r); }

  /// Overlap with the rim of a sphere of radius r whose centre is `rho` from the axis at
  /// height z: r less the distance from the centre to the rim's circle.
  double RimOverlap(double rho, double z, double r) const {
    const double out = rho - radius_m, up = z - height_m;
    return r - std::sqrt(out * out + up * up);
  }

  /// The side wall's contact with a sphere of radius r, centre (x, y, z) at `rho` from the
  /// axis, that touches it (TouchesSideWall): the overlap and the unit normal from the wall
  /// into the sphere. The face pushes towards the axis; the rim along the line from the rim to
  /// the centre (both computed, one selected: no branch for a vector lane).
  void SideWallGeometry(double x, double y, double z, double rho, double r, double& overlap,
                        double& nx, double& ny, double& nz) const {
    const double out = rho - radius_m, up = z - height_m;
    const double to_rim = std::sqrt(out * out + up * up);
    const bool rim = up > 0.0;
    overlap = rim ? r - to_rim : SideWallOverlap(rho, r);
    const double radial = out / to_rim;
    nx = rim ? radial * (x / rho) : -x / rho;
    ny = rim ? radial * (y / rho) : -y / rho;
    nz = rim ? up / to_rim : 0.0;
  }

  /// The container leaked: a centre outside the side wall below its top, or a sphere wholly
  /// through the plate.
  bool Escaped(double x, double y, double z, double r) const {
    return ((z < height_m) & (x * x + y * y > radius_m * radius_m)) | (z < -r);
  }
};

}  // namespace dembuf::dem
