#include "dembuf/study/files/vtk_files.h"

#include <openssl/evp.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <sstream>

namespace dembuf::report {

namespace {

// VTK's inline binary array: base64 of a 32-bit byte count, then the values as they lie in
// memory (the file's byte_order says which way round). Base64 by OpenSSL.
template <class T>
std::string Base64Array(const std::vector<T>& values) {
  const auto bytes = static_cast<std::uint32_t>(values.size() * sizeof(T));
  std::string raw(sizeof bytes + bytes, '\0');
  std::memcpy(raw.data(), &bytes, sizeof bytes);
  if (bytes > 0) std::memcpy(raw.data() + sizeof bytes, values.data(), bytes);
  std::string encoded(4 * ((raw.size() + 2) / 3) + 1, '\0');
  const int length = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(encoded.data()),
                                     reinterpret_cast<const unsigned char*>(raw.data()),
                                     static_cast<int>(raw.size()));
  encoded.resize(static_cast<std::size_t>(length));
  return encoded;
}

template <class T>
constexpr const char* VtkType() {
  if constexpr (std::is_same_v<T, double>) return "Float64";
  if constexpr (std::is_same_v<T, std::int32_t>) return "Int32";
  return "";
}

template <class T>
void Array(std::ostringstream& out, const char* name, int components, const std::vector<T>& v) {
  out << "        <DataArray type=\"" << VtkType<T>() << "\" Name=\"" << name
      << "\" NumberOfComponents=\"" << components << "\" format=\"binary\">" << Base64Array(v)
      << "</DataArray>\n";
}

std::vector<double> Flatten(const std::vector<dem::Vec3>& vectors) {
  std::vector<double> flat;
  flat.reserve(3 * vectors.size());
  for (const dem::Vec3& v : vectors) flat.insert(flat.end(), {v.x(), v.y(), v.z()});
  return flat;
}

const char* ByteOrder() {
  return std::endian::native == std::endian::little ? "LittleEndian" : "BigEndian";
}

// The bodies as points: the beads, then the projectile.
struct Bodies {
  std::vector<dem::Vec3> positions, velocities, forces;
  std::vector<double> radii;
  std::vector<std::int32_t> ids;
};

Bodies BodiesOf(const ImpactSnapshot& s) {
  Bodies b{s.positions, s.velocities, s.forces, s.radii, {}};
  const std::size_t n = s.positions.size();
  b.velocities.resize(n, dem::Vec3::Zero());
  b.forces.resize(n, dem::Vec3::Zero());
  b.ids.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    b.ids[i] = static_cast<std::int32_t>(i < s.ids.size() ? s.ids[i] : i);
  if (s.projectile) {
    b.positions.push_back(s.projectile->position);
    b.velocities.push_back(s.projectile->velocity);
    b.forces.push_back(dem::Vec3::Zero());
    b.radii.push_back(s.projectile->radius);
    b.ids.push_back(-1);
  }
  return b;
}

// A PolyData file of the points, with `cells` ("Verts" or "Lines") given by connectivity and
// offsets, and arrays per point and per cell.
std::string PolyData(const Bodies& b, bool with_point_data, const char* cells,
                     const std::vector<std::int32_t>& connectivity,
                     const std::vector<std::int32_t>& offsets,
                     const std::vector<double>& cell_normal_force) {
  std::ostringstream out;
  const std::size_t cell_count = offsets.size();
  out << "<?xml version=\"1.0\"?>\n"
      << "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"" << ByteOrder()
      << "\" header_type=\"UInt32\">\n  <PolyData>\n"
      << "    <Piece NumberOfPoints=\"" << b.positions.size() << "\" NumberOf" << cells << "=\""
      << cell_count << "\">\n      <Points>\n";
  Array(out, "position_m", 3, Flatten(b.positions));
  out << "      </Points>\n";
  if (with_point_data) {
    out << "      <PointData Scalars=\"radius_m\" Vectors=\"velocity_m_s\">\n";
    Array(out, "radius_m", 1, b.radii);
    Array(out, "velocity_m_s", 3, Flatten(b.velocities));
    Array(out, "id", 1, b.ids);
    Array(out, "force_N", 3, Flatten(b.forces));
    out << "      </PointData>\n";
  }
  if (!cell_normal_force.empty()) {
    out << "      <CellData Scalars=\"normal_force_N\">\n";
    Array(out, "normal_force_N", 1, cell_normal_force);
    out << "      </CellData>\n";
  }
  out << "      <" << cells << ">\n";
  Array(out, "connectivity", 1, connectivity);
  Array(out, "offsets", 1, offsets);
  out << "      </" << cells << ">\n    </Piece>\n  </PolyData>\n</VTKFile>\n";
  return out.str();
}

}  // namespace

std::string BeadsVtp(const ImpactSnapshot& snap) {
  const Bodies bodies = BodiesOf(snap);
  std::vector<std::int32_t> connectivity(bodies.positions.size()), offsets(bodies.positions.size());
  for (std::size_t i = 0; i < connectivity.size(); ++i) {
    connectivity[i] = static_cast<std::int32_t>(i);
    offsets[i] = static_cast<std::int32_t>(i + 1);
  }
  return PolyData(bodies, true, "Verts", connectivity, offsets, {});
}

std::string ContactsVtp(const ImpactSnapshot& snap) {
  const Bodies bodies = BodiesOf(snap);
  const auto projectile = static_cast<std::int32_t>(snap.positions.size());
  std::vector<std::int32_t> connectivity, offsets;
  std::vector<double> normal_force;
  for (const dem::ContactSnapshot& c : snap.contacts) {
    if (!dem::IsBead(c.b)) continue;  // the plate or the wall: no second centre
    const std::int32_t a = c.a == dem::kProjectile ? projectile : static_cast<std::int32_t>(c.a);
    connectivity.insert(connectivity.end(), {a, static_cast<std::int32_t>(c.b)});
    offsets.push_back(static_cast<std::int32_t>(connectivity.size()));
    normal_force.push_back(c.normal_N);
  }
  return PolyData(bodies, false, "Lines", connectivity, offsets, normal_force);
}

std::string ContainerVtp(double radius_m, double height_m) {
  // The plate a polygon of kSides corners at z = 0, the wall kSides quads up to its rim; a
  // cell array says which (0 plate, 1 wall), for colouring them apart.
  constexpr int kSides = 72;
  std::vector<double> points;
  for (const double z : {0.0, height_m})
    for (int k = 0; k < kSides; ++k) {
      const double angle = 2.0 * std::numbers::pi * k / kSides;
      points.insert(points.end(), {radius_m * std::cos(angle), radius_m * std::sin(angle), z});
    }
  std::vector<std::int32_t> connectivity, offsets, part;
  for (int k = 0; k < kSides; ++k) connectivity.push_back(k);
  offsets.push_back(kSides);
  part.push_back(0);
  for (int k = 0; k < kSides; ++k) {
    const int next = (k + 1) % kSides;
    connectivity.insert(connectivity.end(), {k, next, kSides + next, kSides + k});
    offsets.push_back(static_cast<std::int32_t>(connectivity.size()));
    part.push_back(1);
  }
  std::ostringstream out;
  out << "<?xml version=\"1.0\"?>\n"
      << "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"" << ByteOrder()
      << "\" header_type=\"UInt32\">\n  <PolyData>\n"
      << "    <Piece NumberOfPoints=\"" << 2 * kSides << "\" NumberOfPolys=\"" << offsets.size()
      << "\">\n      <Points>\n";
  Array(out, "position_m", 3, points);
  out << "      </Points>\n      <CellData Scalars=\"part\">\n";
  Array(out, "part", 1, part);
  out << "      </CellData>\n      <Polys>\n";
  Array(out, "connectivity", 1, connectivity);
  Array(out, "offsets", 1, offsets);
  out << "      </Polys>\n    </Piece>\n  </PolyData>\n</VTKFile>\n";
  return out.str();
}

std::string BedVtp(const dem::ParticleState& beads) {
  ImpactSnapshot snap;
  snap.positions = beads.position;
  snap.radii = beads.radius;
  snap.velocities = beads.velocity;
  return BeadsVtp(snap);
}

std::string Pvd(std::vector<PvdEntry> entries) {
  std::stable_sort(entries.begin(), entries.end(),
                   [](const PvdEntry& a, const PvdEntry& b) { return a.t_s < b.t_s; });
  std::ostringstream out;
  out.precision(17);
  out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" byte_order=\""
      << ByteOrder() << "\">\n  <Collection>\n";
  for (const PvdEntry& e : entries)
    out << "    <DataSet timestep=\"" << e.t_s << "\" part=\"" << e.part << "\" file=\"" << e.file
        << "\"/>\n";
  out << "  </Collection>\n</VTKFile>\n";
  return out.str();
}

}  // namespace dembuf::report
