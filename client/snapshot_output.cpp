#include "snapshot_output.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>

namespace dembuf::cli {

namespace {

std::string SafeLabel(const std::string& label) {
  std::string out;
  for (char c : label)
    if (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_') out += c;
  return out.empty() ? "snapshot" : out;
}

bool IsBodyPair(const dem::ContactSnapshot& c) {
  return dem::IsBead(c.b);
}

void WriteVtk(const ImpactSnapshot& s, const std::filesystem::path& path) {
  std::ofstream out(path);
  out.precision(9);
  const std::size_t n = s.positions.size();
  const std::size_t points = n + (s.projectile ? 1 : 0);
  out << "# vtk DataFile Version 3.0\ndembuf force network " << s.label << "\nASCII\n"
      << "DATASET POLYDATA\nPOINTS " << points << " double\n";
  for (const dem::Vec3& x : s.positions) out << x.x() << " " << x.y() << " " << x.z() << "\n";
  if (s.projectile)
    out << s.projectile->position.x() << " " << s.projectile->position.y() << " "
        << s.projectile->position.z() << "\n";
  std::size_t lines = 0;
  for (const auto& c : s.contacts) lines += IsBodyPair(c);
  out << "LINES " << lines << " " << 3 * lines << "\n";
  for (const auto& c : s.contacts) {
    if (!IsBodyPair(c)) continue;
    const std::size_t a = c.a == dem::kProjectile ? n : static_cast<std::size_t>(c.a);
    out << "2 " << a << " " << c.b << "\n";
  }
  out << "CELL_DATA " << lines << "\nSCALARS normal_force_N double 1\nLOOKUP_TABLE default\n";
  for (const auto& c : s.contacts)
    if (IsBodyPair(c)) out << c.normal_N << "\n";
  out << "POINT_DATA " << points << "\nSCALARS radius_m double 1\nLOOKUP_TABLE default\n";
  for (double r : s.radii) out << r << "\n";
  if (s.projectile) out << s.projectile->radius << "\n";
}

void WriteContacts(const ImpactSnapshot& s, const std::filesystem::path& path) {
  std::ofstream out(path);
  out.precision(9);
  out << "a,b,x_m,y_m,z_m,fx_N,fy_N,fz_N,normal_N,ax_m,ay_m,az_m,bx_m,by_m,bz_m\n";
  auto centre = [&](dem::BodyId id, const dem::Vec3& point) -> dem::Vec3 {
    if (dem::IsBead(id)) return s.positions[id];
    if (id == dem::kProjectile && s.projectile) return s.projectile->position;
    return point;  // a wall: its contact point
  };
  auto name = [](dem::BodyId id) -> std::string {
    switch (id) {
      case dem::kPlate:
        return "plate";
      case dem::kSideWall:
        return "wall";
      case dem::kProjectile:
        return "projectile";
      default:
        return std::to_string(id);
    }
  };
  for (const auto& c : s.contacts) {
    const dem::Vec3 a = centre(c.a, c.point), b = centre(c.b, c.point);
    out << name(c.a) << "," << name(c.b) << "," << c.point.x() << "," << c.point.y() << ","
        << c.point.z() << "," << c.force.x() << "," << c.force.y() << "," << c.force.z() << ","
        << c.normal_N << "," << a.x() << "," << a.y() << "," << a.z() << "," << b.x() << ","
        << b.y() << "," << b.z() << "\n";
  }
}

void WritePlateLoad(const ImpactSnapshot& s, const std::filesystem::path& dir, double R,
                    double ring_width) {
  const int rings = std::max(1, static_cast<int>(std::ceil(R / ring_width)));
  std::vector<double> ring_force(rings, 0.0);
  constexpr double kCell = 0.01;
  const int cells = static_cast<int>(std::ceil(2.0 * R / kCell));
  std::vector<double> map(cells * cells, 0.0);
  for (const auto& c : s.contacts) {
    if (c.b != dem::kPlate) continue;
    const double rho = std::hypot(c.point.x(), c.point.y());
    ring_force[std::min(rings - 1, static_cast<int>(rho / ring_width))] += c.normal_N;
    const int cx = std::clamp(static_cast<int>((c.point.x() + R) / kCell), 0, cells - 1);
    const int cy = std::clamp(static_cast<int>((c.point.y() + R) / kCell), 0, cells - 1);
    map[cy * cells + cx] += c.normal_N;
  }
  std::ofstream radial(dir / "plate_radial.csv");
  radial << "r_inner_m,r_outer_m,force_N,pressure_Pa\n";
  for (int k = 0; k < rings; ++k) {
    const double r0 = k * ring_width, r1 = std::min(R, (k + 1) * ring_width);
    const double area = std::numbers::pi * (r1 * r1 - r0 * r0);
    radial << r0 << "," << r1 << "," << ring_force[k] << "," << ring_force[k] / area << "\n";
  }
  std::ofstream grid(dir / "plate_map.csv");
  grid << "x_m,y_m,force_N\n";
  for (int cy = 0; cy < cells; ++cy)
    for (int cx = 0; cx < cells; ++cx)
      grid << -R + (cx + 0.5) * kCell << "," << -R + (cy + 0.5) * kCell << ","
           << map[cy * cells + cx] << "\n";
}

void WriteForcePdf(const ImpactSnapshot& s, const std::filesystem::path& path) {
  std::vector<double> forces;
  for (const auto& c : s.contacts)
    if (dem::IsBead(c.a) && dem::IsBead(c.b) && c.normal_N > 0.0) forces.push_back(c.normal_N);
  std::ofstream out(path);
  out << "f_over_mean,pdf,count\n";
  if (forces.empty()) return;
  double mean = 0.0;
  for (double f : forces) mean += f / forces.size();
  // Bins of a tenth of the mean, up to the largest force: every force in its own bin (a last
  // bin that collected the tail would show a false peak at the edge).
  constexpr double kBin = 0.1;
  const double largest = *std::max_element(forces.begin(), forces.end());
  const int bins = static_cast<int>(largest / mean / kBin) + 1;
  std::vector<int> counts(bins, 0);
  for (double f : forces) ++counts[std::min(bins - 1, static_cast<int>(f / mean / kBin))];
  for (int k = 0; k < bins; ++k)
    out << (k + 0.5) * kBin << "," << counts[k] / (forces.size() * kBin) << "," << counts[k]
        << "\n";
}

}  // namespace

std::filesystem::path WriteSnapshot(const ImpactSnapshot& snap, const std::filesystem::path& dir,
                                    double cylinder_radius_m, double bead_diameter_m) {
  const std::filesystem::path folder = dir / "snapshots" / SafeLabel(snap.label);
  std::filesystem::create_directories(folder);
  WriteVtk(snap, folder / "network.vtk");
  WriteContacts(snap, folder / "contacts.csv");
  WritePlateLoad(snap, folder, cylinder_radius_m, bead_diameter_m);
  WriteForcePdf(snap, folder / "force_pdf.csv");
  return folder;
}

}  // namespace dembuf::cli
