// What a Simulation tells about its contacts outside the force pass: the saved tangential
// histories, the contacts with their forces (snapshots) and the energy (tests). Each contact's
// force and stored energy come from the law's one copy (contact_law.h).
#include <cmath>

#include "contact_kernels.h"
#include "simulation_state.h"

namespace dembuf::dem {

std::vector<ContactHistoryEntry> Simulation::ExportHistory() const {
  CompleteKick();
  const Impl& s = *m_impl;
  std::vector<ContactHistoryEntry> out;
  out.insert(out.end(), s.pending_history.begin(), s.pending_history.end());
  for (std::size_t c = 0; c < s.walls.plate.size(); ++c) {
    const std::uint32_t i = s.lists.near_container[c];
    if (s.walls.plate[c] != Vec3::Zero()) out.push_back({i, kPlate, s.walls.plate[c]});
    if (s.walls.side[c] != Vec3::Zero()) out.push_back({i, kSideWall, s.walls.side[c]});
  }
  if (s.lists.pairs.offsets.size() == m_beads.size() + 1) {
    for (std::uint32_t i = 0; i < m_beads.size(); ++i)
      for (std::uint32_t k = s.lists.pairs.offsets[i]; k < s.lists.pairs.offsets[i + 1]; ++k)
        if (s.lists.pairs.shear[k] != Vec3::Zero())
          out.push_back({i, s.lists.pairs.partners[k], s.lists.pairs.shear[k]});
  }
  return out;
}

namespace {

// The constants of the pairs of a bead of species `a` with one of `b`, with a wall and with the
// projectile: the species table's when the world has several.
const PairParams& BeadPair(const WorldParams& params, Species a, Species b) {
  return params.species.count > 1 ? params.species.BeadPair(a, b) : params.sphere_pair;
}
const PairParams& BeadWall(const WorldParams& params, Species a) {
  return params.species.count > 1 ? params.species.bead_wall[a] : params.sphere_wall;
}
const PairParams& ProjectileBead(const WorldParams& params, Species b) {
  return params.species.count > 1 ? params.species.projectile_bead[b] : params.sphere_pair;
}

// Every contact of the current state, with its geometry, for the few places that look at
// contacts outside the force kernel (snapshots, energy). visit(a, b, n, overlap, v_rel,
// radius_a, r_star, params, shear, x_a) with a and b as in ContactSnapshot.
template <class Visit>
void VisitContacts(const WorldParams& params, const ParticleState& b,
                   const std::optional<RigidSphere>& projectile, const Simulation::Impl& s,
                   Visit&& visit) {
  if (s.lists.pairs.offsets.size() == b.size() + 1) {
    for (std::uint32_t i = 0; i < b.size(); ++i)
      for (std::uint32_t k = s.lists.pairs.offsets[i]; k < s.lists.pairs.offsets[i + 1]; ++k) {
        const std::uint32_t j = s.lists.pairs.partners[k];
        const Vec3 d = b.position[i] - b.position[j];
        const double rsum = b.radius[i] + b.radius[j], dist = d.norm();
        if (dist >= rsum) continue;
        visit(i, j, Vec3(d / dist), rsum - dist, Vec3(b.velocity[i] - b.velocity[j]), b.radius[i],
              EffectiveRadius(b.radius[i], b.radius[j]),
              BeadPair(params, b.species[i], b.species[j]), s.lists.pairs.shear[k], b.position[i]);
      }
  }
  auto walls = [&](BodyId id, const Vec3& x, const Vec3& v, double r, const Vec3& plate,
                   const Vec3& wall, const PairParams& with_wall) {
    if (const double overlap = Container::PlateOverlap(x.z(), r); overlap > 0.0)
      visit(id, kPlate, Vec3(Vec3::UnitZ()), overlap, v, r, r, with_wall, plate, x);
    double overlap;
    Vec3 n;
    if (detail::SideWallContact(params.container, x, r, overlap, n))
      visit(id, kSideWall, n, overlap, v, r, r, with_wall, wall, x);
  };
  // Only the near-container beads keep wall histories (in near_container order, by id).
  const Vec3 none = Vec3::Zero();
  for (std::uint32_t i = 0, c = 0; i < b.size(); ++i) {
    const bool kept = c < s.walls.plate.size() && s.lists.near_container[c] == i;
    walls(i, b.position[i], b.velocity[i], b.radius[i], kept ? s.walls.plate[c] : none,
          kept ? s.walls.side[c] : none, BeadWall(params, b.species[i]));
    c += kept;
  }
  if (projectile) {
    const RigidSphere& p = *projectile;
    walls(kProjectile, p.position, p.velocity, p.radius, s.walls.projectile_plate,
          s.walls.projectile_side, params.sphere_wall);
    for (std::size_t k = 0; k < s.lists.near_projectile.beads.size(); ++k) {
      const std::uint32_t j = s.lists.near_projectile.beads[k];
      const Vec3 d = p.position - b.position[j];
      const double rsum = p.radius + b.radius[j], dist = d.norm();
      if (dist >= rsum) continue;
      visit(kProjectile, j, Vec3(d / dist), rsum - dist, Vec3(p.velocity - b.velocity[j]), p.radius,
            EffectiveRadius(p.radius, b.radius[j]), ProjectileBead(params, b.species[j]),
            s.lists.near_projectile.shear[k], p.position);
    }
  }
}

}  // namespace

std::vector<ContactSnapshot> Simulation::Contacts() const {
  CompleteKick();
  std::vector<ContactSnapshot> out;
  // Normal force from the law with the current velocities, tangential from the stored spring
  // (already capped by Coulomb in the last step).
  VisitContacts(
      m_params, m_beads, m_projectile, *m_impl,
      [&](BodyId a, BodyId other, const Vec3& n, double overlap, const Vec3& v_rel, double ra,
          double r_star, const PairParams& p, const Vec3& shear, const Vec3& x_a) {
        const double fn = HertzNormal::Force(overlap, -v_rel.dot(n), r_star, p);
        const Vec3 ft = MindlinTangential::StoredSpringForce(overlap, r_star, p, shear);
        out.push_back({a, other, x_a - detail::LeverArm(ra, overlap) * n, fn * n + ft, fn});
      });
  return out;
}

EnergyBreakdown Simulation::Energy() const {
  CompleteKick();
  EnergyBreakdown e;
  const double g = m_params.gravity_m_s2;
  const ParticleState& b = m_beads;
  for (std::size_t i = 0; i < b.size(); ++i) {
    e.kinetic_J += b.KineticEnergy(i);
    e.potential_J += b.mass[i] * g * b.position[i].z();
  }
  if (m_projectile) {
    const RigidSphere& p = *m_projectile;
    e.kinetic_J += 0.5 * p.mass * p.velocity.squaredNorm() +
                   0.5 * p.Inertia() * p.angular_velocity.squaredNorm();
    e.potential_J += p.mass * g * p.position.z();
  }
  VisitContacts(m_params, m_beads, m_projectile, *m_impl,
                [&](std::int64_t, std::int64_t, const Vec3&, double overlap, const Vec3&, double,
                    double r_star, const PairParams& p, const Vec3& shear, const Vec3&) {
                  e.elastic_J += ContactElasticEnergy(overlap, r_star, p, shear);
                });
  return e;
}

}  // namespace dembuf::dem
