// Bed files: a short text header of "key=value" lines, then the beads and contact springs as
// raw little-endian doubles (exact), then an FNV-1a checksum of those bytes.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/text/sha256.h"

namespace dembuf {

namespace {

constexpr const char* kMagic = "dembuf-bed 1";

class Checksum {
 public:
  void Add(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) {
      m_h ^= p[i];
      m_h *= 0x100000001b3ULL;
    }
  }
  std::uint64_t value() const { return m_h; }

 private:
  std::uint64_t m_h = 0xcbf29ce484222325ULL;
};

template <class T>
void Put(std::ostream& out, Checksum& sum, const T& v) {
  out.write(reinterpret_cast<const char*>(&v), sizeof v);
  sum.Add(&v, sizeof v);
}

template <class T>
T Get(std::istream& in, Checksum& sum, const std::string& path) {
  T v;
  if (!in.read(reinterpret_cast<char*>(&v), sizeof v))
    throw std::runtime_error("bed file " + path + " is truncated");
  sum.Add(&v, sizeof v);
  return v;
}

// A text as one header line: a line break (or another control character) in it would start
// a line of its own, which a reader would take for a key of the header.
std::string HeaderValue(std::string text) {
  for (char& c : text)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  return text;
}

std::string Exact(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

std::string SerializeBed(const PreparedBed& bed) {
  std::ostringstream out(std::ios::binary);
  out << kMagic << "\n"
      << "hash=" << bed.hash << "\n"
      << "stage=" << bed.stage << "\n"
      << "surface_m=" << Exact(bed.surface_m) << "\n"
      << "solid_fraction=" << Exact(bed.solid_fraction) << "\n"
      << "weight_N=" << Exact(bed.weight_N) << "\n"
      << "plate_force_N=" << Exact(bed.plate_force_N) << "\n"
      << "wall_force_z_N=" << Exact(bed.wall_force_z_N) << "\n"
      << "kinetic_ratio=" << Exact(bed.kinetic_ratio) << "\n"
      << "settle_time_s=" << Exact(bed.settle_time_s) << "\n"
      << "settle_steps=" << bed.settle_steps << "\n"
      << "wall_time_s=" << Exact(bed.wall_time_s) << "\n"
      << "insert_time_s=" << Exact(bed.insert_time_s) << "\n"
      << "note=" << HeaderValue(bed.note) << "\n";
  for (const std::string& w : bed.warnings) out << "warning=" << HeaderValue(w) << "\n";
  // A bed of one species is written as beds always were (its bytes, so its content hash, as
  // before species existed); one of several adds each bead's species after the springs.
  const dem::ParticleState& beads = bed.beads;
  auto any = [](const std::vector<std::uint8_t>& labels) {
    return std::any_of(labels.begin(), labels.end(), [](std::uint8_t k) { return k != 0; });
  };
  const bool species = any(beads.species), layers = any(beads.layer);
  if (species) out << "species=per bead\n";
  if (layers) out << "layers=per bead\n";
  out << "data\n";
  Checksum sum;
  const dem::ParticleState& b = bed.beads;
  Put<std::uint64_t>(out, sum, b.size());
  for (std::size_t i = 0; i < b.size(); ++i) {
    for (int d = 0; d < 3; ++d) Put(out, sum, b.position[i][d]);
    Put(out, sum, b.radius[i]);
    Put(out, sum, b.mass[i]);
    for (int d = 0; d < 3; ++d) Put(out, sum, b.velocity[i][d]);
    for (int d = 0; d < 3; ++d) Put(out, sum, b.angular_velocity[i][d]);
  }
  Put<std::uint64_t>(out, sum, bed.history.size());
  for (const dem::ContactHistoryEntry& h : bed.history) {
    Put(out, sum, h.bead);
    Put(out, sum, h.other);
    for (int d = 0; d < 3; ++d) Put(out, sum, h.shear[d]);
  }
  if (species)
    for (const dem::Species k : beads.species) Put(out, sum, k);
  if (layers)
    for (const std::uint8_t k : beads.layer) Put(out, sum, k);
  const std::uint64_t check = sum.value();
  out.write(reinterpret_cast<const char*>(&check), sizeof check);
  return std::move(out).str();
}

std::string BedContentSha256(const PreparedBed& bed) {
  const std::string bytes = SerializeBed(bed);
  constexpr std::string_view kDataLine = "\ndata\n";
  const std::size_t data = bytes.find(kDataLine);
  return Sha256Hex(std::string_view(bytes).substr(data + kDataLine.size()));
}

PreparedBed ParseBed(const std::string& bytes, const std::string& name) {
  std::istringstream in(bytes, std::ios::binary);
  std::string line;
  if (!std::getline(in, line) || line != kMagic)
    throw std::runtime_error(name + " is not a dembuf bed");
  PreparedBed bed;
  bool species = false, layers = false;  // each bead's species, then layer, follow the springs
  while (std::getline(in, line) && line != "data") {
    const auto eq = line.find('=');
    if (eq == std::string::npos) throw std::runtime_error(name + ": bad header line " + line);
    const std::string key = line.substr(0, eq), value = line.substr(eq + 1);
    if (key == "hash")
      bed.hash = value;
    else if (key == "stage")
      bed.stage = value;
    else if (key == "surface_m")
      bed.surface_m = std::stod(value);
    else if (key == "solid_fraction")
      bed.solid_fraction = std::stod(value);
    else if (key == "weight_N")
      bed.weight_N = std::stod(value);
    else if (key == "plate_force_N")
      bed.plate_force_N = std::stod(value);
    else if (key == "wall_force_z_N")
      bed.wall_force_z_N = std::stod(value);
    else if (key == "kinetic_ratio")
      bed.kinetic_ratio = std::stod(value);
    else if (key == "settle_time_s")
      bed.settle_time_s = std::stod(value);
    else if (key == "settle_steps")
      bed.settle_steps = std::stoll(value);
    else if (key == "wall_time_s")
      bed.wall_time_s = std::stod(value);
    else if (key == "insert_time_s")
      bed.insert_time_s = std::stod(value);
    else if (key == "note")
      bed.note = value;
    else if (key == "warning")
      bed.warnings.push_back(value);
    else if (key == "species")
      species = value == "per bead";
    else if (key == "layers")
      layers = value == "per bead";
  }
  Checksum sum;
  const auto n = Get<std::uint64_t>(in, sum, name);
  if (n > (1ULL << 32)) throw std::runtime_error(name + ": implausible bead count");
  dem::ParticleState& b = bed.beads;
  for (std::uint64_t i = 0; i < n; ++i) {
    dem::Vec3 x, v, w;
    for (int d = 0; d < 3; ++d) x[d] = Get<double>(in, sum, name);
    const double r = Get<double>(in, sum, name);
    const double m = Get<double>(in, sum, name);
    for (int d = 0; d < 3; ++d) v[d] = Get<double>(in, sum, name);
    for (int d = 0; d < 3; ++d) w[d] = Get<double>(in, sum, name);
    b.position.push_back(x);
    b.velocity.push_back(v);
    b.angular_velocity.push_back(w);
    b.force.push_back(dem::Vec3::Zero());
    b.torque.push_back(dem::Vec3::Zero());
    b.radius.push_back(r);
    b.mass.push_back(m);
    b.inv_mass.push_back(1.0 / m);
  }
  const auto h = Get<std::uint64_t>(in, sum, name);
  if (h > 64 * n + 64) throw std::runtime_error(name + ": implausible contact count");
  for (std::uint64_t k = 0; k < h; ++k) {
    dem::ContactHistoryEntry e;
    e.bead = Get<std::uint32_t>(in, sum, name);
    e.other = Get<std::uint32_t>(in, sum, name);
    for (int d = 0; d < 3; ++d) e.shear[d] = Get<double>(in, sum, name);
    // The simulation indexes its beads by these ids: a contact joins a bead of this file to
    // another one or to a wall.
    const bool wall = e.other == dem::kPlate || e.other == dem::kSideWall;
    if (e.bead >= n || (!wall && (e.other >= n || e.other == e.bead)))
      throw std::runtime_error(name + ": contact " + std::to_string(k) + " joins bead " +
                               std::to_string(e.bead) + " to body " + std::to_string(e.other) +
                               ", not two of its " + std::to_string(n) +
                               " beads or a bead and a wall");
    bed.history.push_back(e);
  }
  b.species.assign(n, 0);
  if (species)
    for (std::uint64_t i = 0; i < n; ++i) b.species[i] = Get<dem::Species>(in, sum, name);
  b.layer.assign(n, 0);
  if (layers)
    for (std::uint64_t i = 0; i < n; ++i) b.layer[i] = Get<std::uint8_t>(in, sum, name);
  std::uint64_t check = 0;
  if (!in.read(reinterpret_cast<char*>(&check), sizeof check) || check != sum.value())
    throw std::runtime_error(name + " is damaged (checksum mismatch)");
  return bed;
}

void SaveBed(const PreparedBed& bed, const std::filesystem::path& path) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary);
    const std::string bytes = SerializeBed(bed);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) throw std::runtime_error("cannot write bed file " + tmp.string());
  }
  std::filesystem::rename(tmp, path);
}

PreparedBed LoadBed(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open bed file " + path.string());
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return ParseBed(std::move(bytes).str(), path.string());
}

FolderBedStore::FolderBedStore(std::filesystem::path dir) : m_dir(std::move(dir)) {
  std::filesystem::create_directories(m_dir);
}

std::optional<PreparedBed> FolderBedStore::Load(const std::string& hash) {
  const auto path = m_dir / (hash + ".bed");
  if (!std::filesystem::exists(path)) return std::nullopt;
  return LoadBed(path);
}

void FolderBedStore::Save(const PreparedBed& bed) {
  SaveBed(bed, m_dir / (bed.hash + ".bed"));
}

BedCache::BedCache(std::filesystem::path dir)
    // Without a store, memory is the only copy: keep every bed, so none is settled twice.
    : BedCache(dir.empty() ? nullptr : std::make_shared<FolderBedStore>(dir),
               dir.empty() ? std::numeric_limits<std::size_t>::max() : 16) {}

BedCache::BedCache(std::shared_ptr<BedStore> store, std::size_t beds_in_memory)
    : m_store(std::move(store)), m_memory_limit(beds_in_memory) {}

void BedCache::RememberLocked(const PreparedBed& bed) {
  if (m_memory_limit == 0) return;
  m_memory[bed.hash] = bed;
  m_memory_order.remove(bed.hash);
  m_memory_order.push_back(bed.hash);
  while (m_memory.size() > m_memory_limit) {
    m_memory.erase(m_memory_order.front());
    m_memory_order.pop_front();
  }
}

std::optional<PreparedBed> BedCache::FindLocked(const std::string& hash) {
  if (auto it = m_memory.find(hash); it != m_memory.end()) return it->second;
  if (!m_store) return std::nullopt;
  try {
    std::optional<PreparedBed> bed = m_store->Load(hash);
    if (!bed || bed->hash != hash) return std::nullopt;
    RememberLocked(*bed);
    return bed;
  } catch (const std::exception&) {
    return std::nullopt;  // a damaged bed is prepared again (and replaced)
  }
}

PreparedBed BedCache::FindOrMake(const std::string& hash, const std::string& stage,
                                 const std::function<PreparedBed()>& make) {
  {
    std::unique_lock lock(m_mutex);
    m_done.wait(lock, [&] { return !m_in_progress.count(hash); });
    if (auto found = FindLocked(hash)) return *found;
    m_in_progress.insert(hash);
  }
  // Prepare without holding the lock; whatever happens, release the waiters.
  try {
    PreparedBed bed = make();
    std::function<void(const PreparedBed&)> on_prepared;
    {
      std::lock_guard lock(m_mutex);
      // Kept in memory first: if the store cannot take it (a full disk), the next attempt
      // still finds the bed instead of settling it again.
      RememberLocked(bed);
      if (m_store) m_store->Save(bed);
      ++m_prepared[stage];
      m_in_progress.erase(hash);
      on_prepared = m_on_prepared;
    }
    m_done.notify_all();
    if (on_prepared) on_prepared(bed);
    return bed;
  } catch (...) {
    {
      std::lock_guard lock(m_mutex);
      m_in_progress.erase(hash);
    }
    m_done.notify_all();
    throw;
  }
}

bool BedCache::Contains(const std::string& hash) {
  std::lock_guard lock(m_mutex);
  return m_memory.count(hash) || (m_store && m_store->Contains(hash));
}

void BedCache::OnPrepared(std::function<void(const PreparedBed&)> callback) {
  std::lock_guard lock(m_mutex);
  m_on_prepared = std::move(callback);
}

std::map<std::string, int> BedCache::prepared_counts() const {
  std::lock_guard lock(m_mutex);
  return m_prepared;
}

}  // namespace dembuf
