#include "dembuf/study/files/snapshot_report.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "dembuf/study/files/run_output.h"

namespace dembuf::report {

namespace {

bool IsSafeNameChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_';
}

// The names of a snapshot's files (SnapshotFiles), in its folder.
constexpr std::array<std::string_view, kSnapshotFileCount> kSnapshotFileNames = {
    "snapshot.json",    "beads.vtp",     "contacts.vtp", "contacts.csv",
    "plate_radial.csv", "plate_map.csv", "force_pdf.csv"};
static_assert(std::none_of(kSnapshotFileNames.begin(), kSnapshotFileNames.end(),
                           [](std::string_view name) { return name.empty(); }),
              "every snapshot file of kSnapshotFileCount is named");

// A folder or file name of letters, digits, '.', '-' and '_', not hidden (no leading dot).
std::string SafeLabel(const std::string& label) {
  std::string out;
  for (char c : label)
    if (IsSafeNameChar(c) && !(out.empty() && c == '.')) out += c;
  if (out.empty()) return "snapshot";
  return out.substr(0, 64);
}

bool IsLabel(std::string_view name) {
  return !name.empty() && name.size() <= 64 && name.front() != '.' &&
         std::all_of(name.begin(), name.end(), IsSafeNameChar);
}

// Text built like a file: full precision for coordinates and forces.
std::ostringstream TextFile() {
  std::ostringstream out;
  out.precision(9);
  return out;
}

std::string Metadata(const ImpactSnapshot& s) {
  std::size_t bead_pairs = 0;
  for (const auto& c : s.contacts) bead_pairs += dem::IsBead(c.a) && dem::IsBead(c.b);
  nlohmann::json j = {{"label", s.label},
                      {"t_s", s.t_s},
                      {"t_after_contact_s", nullptr},
                      {"beads", s.positions.size()},
                      {"contacts", s.contacts.size()},
                      {"bead_bead_contacts", bead_pairs}};
  if (std::isfinite(s.t_after_contact_s)) j["t_after_contact_s"] = s.t_after_contact_s;
  if (s.projectile) {
    const dem::Vec3& x = s.projectile->position;
    j["projectile"] = {
        {"x_m", x.x()}, {"y_m", x.y()}, {"z_m", x.z()}, {"radius_m", s.projectile->radius}};
  }
  return j.dump(2) + "\n";
}

std::string Contacts(const ImpactSnapshot& s) {
  std::ostringstream out = TextFile();
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
  return out.str();
}

// plate_radial.csv and plate_map.csv.
std::pair<std::string, std::string> PlateLoad(const ImpactSnapshot& s, double R,
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
  std::ostringstream radial = TextFile();
  radial << "r_inner_m,r_outer_m,force_N,pressure_Pa\n";
  for (int k = 0; k < rings; ++k) {
    const double r0 = k * ring_width, r1 = std::min(R, (k + 1) * ring_width);
    const double area = std::numbers::pi * (r1 * r1 - r0 * r0);
    radial << r0 << "," << r1 << "," << ring_force[k] << "," << ring_force[k] / area << "\n";
  }
  std::ostringstream grid = TextFile();
  grid << "x_m,y_m,force_N\n";
  for (int cy = 0; cy < cells; ++cy)
    for (int cx = 0; cx < cells; ++cx)
      grid << -R + (cx + 0.5) * kCell << "," << -R + (cy + 0.5) * kCell << ","
           << map[cy * cells + cx] << "\n";
  return {radial.str(), grid.str()};
}

std::string ForcePdf(const ImpactSnapshot& s) {
  std::vector<double> forces;
  for (const auto& c : s.contacts)
    if (dem::IsBead(c.a) && dem::IsBead(c.b) && c.normal_N > 0.0) forces.push_back(c.normal_N);
  std::ostringstream out = TextFile();
  out << "f_over_mean,pdf,count\n";
  if (forces.empty()) return out.str();
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
  return out.str();
}

}  // namespace

std::vector<ResultFile> SnapshotFiles(const ImpactSnapshot& snap, double cylinder_radius_m,
                                      double bead_diameter_m) {
  const std::string folder = "snapshots/" + SafeLabel(snap.label) + "/";
  auto [radial, map] = PlateLoad(snap, cylinder_radius_m, bead_diameter_m);
  // In the order of kSnapshotFileNames, the allow-list of IsResultFileName.
  return {
      {folder + "snapshot.json", Metadata(snap)},       {folder + "beads.vtp", BeadsVtp(snap)},
      {folder + "contacts.vtp", ContactsVtp(snap)},     {folder + "contacts.csv", Contacts(snap)},
      {folder + "plate_radial.csv", std::move(radial)}, {folder + "plate_map.csv", std::move(map)},
      {folder + "force_pdf.csv", ForcePdf(snap)}};
}

void ParaViewFiles::AddContainerOnce(std::vector<ResultFile>& files) {
  if (m_container_written) return;
  m_container_written = true;
  files.push_back({"container.vtp", ContainerVtp(m_cylinder_radius_m, m_cylinder_height_m)});
}

std::vector<ResultFile> ParaViewFiles::AddSnapshot(const ImpactSnapshot& snap) {
  std::vector<ResultFile> files = SnapshotFiles(snap, m_cylinder_radius_m, m_bead_diameter_m);
  AddContainerOnce(files);
  const std::string folder = "snapshots/" + SafeLabel(snap.label) + "/";
  m_snapshots.push_back({snap.t_s, 0, folder + "beads.vtp"});
  m_snapshots.push_back({snap.t_s, 1, folder + "contacts.vtp"});
  m_snapshots.push_back({snap.t_s, 2, "container.vtp"});
  files.push_back({"snapshots.pvd", Pvd(m_snapshots)});
  return files;
}

std::vector<ResultFile> ParaViewFiles::AddFrame(const ImpactSnapshot& frame) {
  std::vector<ResultFile> files;
  AddContainerOnce(files);
  const std::string path = FramePath(frame, ".vtp");
  m_frames.push_back({frame.t_s, 0, path});
  m_frames.push_back({frame.t_s, 1, "container.vtp"});
  files.push_back({path, BeadsVtp(frame)});
  files.push_back({"frames.pvd", Pvd(m_frames)});
  return files;
}

std::string FramePath(const ImpactSnapshot& frame, std::string_view extension) {
  return "frames/" + SafeLabel(frame.label) + std::string(extension);
}

bool IsSafeResultPath(std::string_view path) {
  if (path.empty() || path.size() > kMaxResultPathLength) return false;
  int depth = 0;
  std::size_t start = 0;
  while (start <= path.size()) {
    const std::size_t end = std::min(path.find('/', start), path.size());
    const std::string_view name = path.substr(start, end - start);
    if (name.empty() || name == "." || name == "..") return false;
    if (!std::all_of(name.begin(), name.end(), IsSafeNameChar)) return false;
    if (++depth > kMaxResultPathDepth) return false;
    start = end + 1;
  }
  return true;
}

const std::vector<std::string>& ResultFileRoots() {
  static const std::vector<std::string> roots = {run_files::kPlateForceBare,
                                                 "snapshots",
                                                 "snapshots.pvd",
                                                 "frames",
                                                 "frames.pvd",
                                                 "container.vtp"};
  return roots;
}

bool IsResultFileName(std::string_view path) {
  if (path == run_files::kPlateForceBare || path == "snapshots.pvd" || path == "frames.pvd" ||
      path == "container.vtp")
    return true;
  constexpr std::string_view kSnapshots = "snapshots/", kFrames = "frames/";
  if (path.substr(0, kFrames.size()) == kFrames) {
    const std::string_view name = path.substr(kFrames.size());
    for (const std::string_view extension : {".vtp", ".dump"})  // FramePath's
      if (name.size() > extension.size() &&
          name.substr(name.size() - extension.size()) == extension &&
          IsLabel(name.substr(0, name.size() - extension.size())))
        return true;
    return false;
  }
  if (path.substr(0, kSnapshots.size()) != kSnapshots) return false;
  const std::string_view rest = path.substr(kSnapshots.size());
  const std::size_t slash = rest.find('/');
  if (slash == std::string_view::npos || !IsLabel(rest.substr(0, slash))) return false;
  return std::find(kSnapshotFileNames.begin(), kSnapshotFileNames.end(), rest.substr(slash + 1)) !=
         kSnapshotFileNames.end();
}

void WriteResultFiles(const std::vector<ResultFile>& files, const std::filesystem::path& dir) {
  for (const ResultFile& f : files)
    if (!IsSafeResultPath(f.path))
      throw std::runtime_error("refused a result file named \"" + f.path.substr(0, 80) +
                               "\": not a plain relative path");
  for (const ResultFile& f : files) {
    const std::filesystem::path path = dir / f.path;
    std::filesystem::create_directories(path.parent_path());
    WriteFileAtomically(path, f.data);
  }
}

}  // namespace dembuf::report
