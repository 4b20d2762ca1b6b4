#include "dembuf/study/files/bed_export.h"

#include <algorithm>
#include <numbers>
#include <sstream>

#include "dembuf/study/files/vtk_files.h"
#include "dembuf/study/scene/species.h"

namespace dembuf {

std::span<const BedFormatName> BedFormatNames() {
  static constexpr BedFormatName names[] = {
      {BedFormat::kText, "text", "x y z radius, as bed.import reads"},
      {BedFormat::kLammps, "lammps", "a data file for read_data, atom_style sphere"},
      {BedFormat::kVtp, "vtp", "VTK XML, for ParaView"}};
  return names;
}

std::optional<BedFormat> ParseBedFormat(std::string_view name) {
  for (const BedFormatName& f : BedFormatNames())
    if (f.name == name) return f.format;
  return std::nullopt;
}

namespace {

std::string Text(const dem::ParticleState& beads, const std::string& title) {
  std::ostringstream out;
  out.precision(17);
  // A bed of several species gets a header with a type column (bed.import_types reads it).
  const bool species = std::any_of(beads.species.begin(), beads.species.end(),
                                   [](dem::Species k) { return k != 0; });
  out << "# " << title << "\n# " << beads.size() << " beads: x_m y_m z_m radius_m"
      << (species ? " type (species)" : "") << "\n";
  if (species) out << "x_m y_m z_m radius_m type\n";
  for (std::size_t i = 0; i < beads.size(); ++i) {
    out << beads.position[i].x() << " " << beads.position[i].y() << " " << beads.position[i].z()
        << " " << beads.radius[i];
    if (species) out << " " << beads.species[i] + 1;
    out << "\n";
  }
  return out.str();
}

double Density(double mass, double radius) {
  const double d = 2.0 * radius;
  return mass / (std::numbers::pi / 6.0 * d * d * d);
}

std::string LammpsData(const dem::ParticleState& beads, const Scene& scene,
                       const std::string& title,
                       const std::optional<dem::RigidSphere>& projectile) {
  std::ostringstream out;
  out.precision(17);
  // The box holds the cylinder (5 mm around it) from just below the plate to its rim, or to
  // 1 cm above the highest body.
  const double r = scene.cylinder.radius_m + 0.005;
  double top = scene.cylinder.height_m;
  for (std::size_t i = 0; i < beads.size(); ++i)
    top = std::max(top, beads.position[i].z() + beads.radius[i] + 0.01);
  if (projectile) top = std::max(top, projectile->position.z() + projectile->radius + 0.01);
  const std::size_t atoms = beads.size() + (projectile ? 1 : 0);
  // Atom type k is species k (bed.import_types reads them back so); the projectile's type
  // follows the species'. The title line names them.
  int species = 1;
  for (const dem::Species k : beads.species) species = std::max(species, k + 1);
  std::string types;
  for (int k = 0; k < species; ++k)
    types += (k ? ", " : "") + std::to_string(k + 1) + " " + SpeciesOf(scene, k).name;
  if (projectile) types += ", " + std::to_string(species + 1) + " projectile";
  out << "LAMMPS data file: " << title << "; atom types " << types << "\n\n"
      << atoms << " atoms\n"
      << species + (projectile ? 1 : 0) << " atom types\n\n"
      << -r << " " << r << " xlo xhi\n"
      << -r << " " << r << " ylo yhi\n"
      << -0.001 << " " << top << " zlo zhi\n\nAtoms # sphere\n\n";
  for (std::size_t i = 0; i < beads.size(); ++i)
    out << i + 1 << " " << (i < beads.species.size() ? beads.species[i] + 1 : 1) << " "
        << 2.0 * beads.radius[i] << " " << Density(beads.mass[i], beads.radius[i]) << " "
        << beads.position[i].x() << " " << beads.position[i].y() << " " << beads.position[i].z()
        << "\n";
  if (projectile)
    out << atoms << " " << species + 1 << " " << 2.0 * projectile->radius << " "
        << Density(projectile->mass, projectile->radius) << " " << projectile->position.x() << " "
        << projectile->position.y() << " " << projectile->position.z() << "\n";
  out << "\nVelocities\n\n";
  for (std::size_t i = 0; i < beads.size(); ++i) {
    const dem::Vec3& v = beads.velocity[i];
    const dem::Vec3& w = beads.angular_velocity[i];
    out << i + 1 << " " << v.x() << " " << v.y() << " " << v.z() << " " << w.x() << " " << w.y()
        << " " << w.z() << "\n";
  }
  if (projectile) {
    const dem::Vec3& v = projectile->velocity;
    out << atoms << " " << v.x() << " " << v.y() << " " << v.z() << " 0 0 0\n";
  }
  return out.str();
}

}  // namespace

std::string ExportBed(const dem::ParticleState& beads, const Scene& scene, BedFormat format,
                      const std::string& title, const std::optional<dem::RigidSphere>& projectile) {
  switch (format) {
    case BedFormat::kText:
      return Text(beads, title);
    case BedFormat::kLammps:
      return LammpsData(beads, scene, title, projectile);
    case BedFormat::kVtp:
      break;
  }
  return report::BedVtp(beads);
}

}  // namespace dembuf
