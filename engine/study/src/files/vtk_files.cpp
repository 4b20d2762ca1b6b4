#include "dembuf/study/files/vtk_files.h"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace dembuf::report {

namespace {

template <class T>
constexpr const char* VtkType() {
  if constexpr (std::is_same_v<T, double>) return "Float64";
  if constexpr (std::is_same_v<T, std::int32_t>) return "Int32";
  return "";
}

// A VTK XML file whose arrays lie, zlib-compressed, in one raw block after the XML (VTK's
// "appended" format with vtkZLibDataCompressor): a third to a half of the inline base64 it
// replaces, and read by ParaView and VTK as they are. Each array is compressed in blocks of
// kBlockBytes behind a header of UInt32s: the block count, the block size, the size of a
// partial last block (0 when the last is full), then each block's compressed size.
class AppendedArrays {
 public:
  template <class T>
  void Array(std::ostringstream& out, const char* name, int components,
             const std::vector<T>& values) {
    out << "        <DataArray type=\"" << VtkType<T>() << "\" Name=\"" << name
        << "\" NumberOfComponents=\"" << components << "\" format=\"appended\" offset=\""
        << m_data.size() << "\"/>\n";
    Append(reinterpret_cast<const unsigned char*>(values.data()), values.size() * sizeof(T));
  }

  // The file's end: the data block and the closing tag.
  void Close(std::ostringstream& out) const {
    out << "  <AppendedData encoding=\"raw\">\n   _" << m_data
        << "\n  </AppendedData>\n</VTKFile>\n";
  }

 private:
  static constexpr std::size_t kBlockBytes = 1 << 15;

  void Append(const unsigned char* bytes, std::size_t size) {
    const std::size_t blocks = (size + kBlockBytes - 1) / kBlockBytes;
    std::vector<std::uint32_t> header = {static_cast<std::uint32_t>(blocks),
                                         static_cast<std::uint32_t>(kBlockBytes),
                                         static_cast<std::uint32_t>(size % kBlockBytes)};
    std::string compressed;
    std::vector<unsigned char> block(compressBound(kBlockBytes));
    for (std::size_t k = 0; k < blocks; ++k) {
      const std::size_t from = k * kBlockBytes, length = std::min(kBlockBytes, size - from);
      uLongf out_size = block.size();
      if (compress2(block.data(), &out_size, bytes + from, length, Z_DEFAULT_COMPRESSION) != Z_OK)
        throw std::runtime_error("zlib could not compress a VTK array");
      header.push_back(static_cast<std::uint32_t>(out_size));
      compressed.append(reinterpret_cast<const char*>(block.data()), out_size);
    }
    m_data.append(reinterpret_cast<const char*>(header.data()), header.size() * sizeof header[0]);
    m_data += compressed;
  }

  std::string m_data;
};

const char* ByteOrder() {
  return std::endian::native == std::endian::little ? "LittleEndian" : "BigEndian";
}

// The opening of a PolyData file with appended compressed arrays.
void OpenPolyData(std::ostringstream& out) {
  out << "<?xml version=\"1.0\"?>\n"
      << "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"" << ByteOrder()
      << "\" header_type=\"UInt32\" compressor=\"vtkZLibDataCompressor\">\n  <PolyData>\n";
}

std::vector<double> Flatten(const std::vector<dem::Vec3>& vectors) {
  std::vector<double> flat;
  flat.reserve(3 * vectors.size());
  for (const dem::Vec3& v : vectors) flat.insert(flat.end(), {v.x(), v.y(), v.z()});
  return flat;
}

// The bodies as points: the beads, then the projectile.
struct Bodies {
  std::vector<dem::Vec3> positions, velocities, forces;
  std::vector<double> radii;
  std::vector<std::int32_t> ids;
  std::vector<std::int32_t> species;  ///< 1, 2, 3 as the scene numbers them; 0: the projectile
};

Bodies BodiesOf(const ImpactSnapshot& s) {
  Bodies b{s.positions, s.velocities, s.forces, s.radii, {}, {}};
  const std::size_t n = s.positions.size();
  b.velocities.resize(n, dem::Vec3::Zero());
  b.forces.resize(n, dem::Vec3::Zero());
  b.ids.resize(n);
  b.species.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    b.ids[i] = static_cast<std::int32_t>(i < s.ids.size() ? s.ids[i] : i);
    b.species[i] = 1 + (i < s.species.size() ? s.species[i] : 0);
  }
  if (s.projectile) {
    b.positions.push_back(s.projectile->position);
    b.velocities.push_back(s.projectile->velocity);
    b.forces.push_back(dem::Vec3::Zero());
    b.radii.push_back(s.projectile->radius);
    b.ids.push_back(-1);
    b.species.push_back(0);
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
  AppendedArrays arrays;
  const std::size_t cell_count = offsets.size();
  OpenPolyData(out);
  out << "    <Piece NumberOfPoints=\"" << b.positions.size() << "\" NumberOf" << cells << "=\""
      << cell_count << "\">\n      <Points>\n";
  arrays.Array(out, "position_m", 3, Flatten(b.positions));
  out << "      </Points>\n";
  if (with_point_data) {
    out << "      <PointData Scalars=\"radius_m\" Vectors=\"velocity_m_s\">\n";
    arrays.Array(out, "radius_m", 1, b.radii);
    arrays.Array(out, "velocity_m_s", 3, Flatten(b.velocities));
    arrays.Array(out, "id", 1, b.ids);
    arrays.Array(out, "species", 1, b.species);
    arrays.Array(out, "force_N", 3, Flatten(b.forces));
    out << "      </PointData>\n";
  }
  if (!cell_normal_force.empty()) {
    out << "      <CellData Scalars=\"normal_force_N\">\n";
    arrays.Array(out, "normal_force_N", 1, cell_normal_force);
    out << "      </CellData>\n";
  }
  out << "      <" << cells << ">\n";
  arrays.Array(out, "connectivity", 1, connectivity);
  arrays.Array(out, "offsets", 1, offsets);
  out << "      </" << cells << ">\n    </Piece>\n  </PolyData>\n";
  arrays.Close(out);
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
  AppendedArrays arrays;
  OpenPolyData(out);
  out << "    <Piece NumberOfPoints=\"" << 2 * kSides << "\" NumberOfPolys=\"" << offsets.size()
      << "\">\n      <Points>\n";
  arrays.Array(out, "position_m", 3, points);
  out << "      </Points>\n      <CellData Scalars=\"part\">\n";
  arrays.Array(out, "part", 1, part);
  out << "      </CellData>\n      <Polys>\n";
  arrays.Array(out, "connectivity", 1, connectivity);
  arrays.Array(out, "offsets", 1, offsets);
  out << "      </Polys>\n    </Piece>\n  </PolyData>\n";
  arrays.Close(out);
  return out.str();
}

std::string BedVtp(const dem::ParticleState& beads) {
  ImpactSnapshot snap;
  snap.positions = beads.position;
  snap.radii = beads.radius;
  snap.species = beads.species;
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
