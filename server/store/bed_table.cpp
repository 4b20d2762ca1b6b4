#include "store/bed_table.h"

#include "dembuf/study/files/provenance.h"
#include "dembuf/study/text/sha256.h"

namespace dembuf::server {

void BedTable::RecordBedPreparation(const std::string& hash, const std::string& stage,
                                    std::int64_t job_id) {
  Connection::Writing db = m_connection.Write();
  db->Prepare("INSERT INTO bed_preparations (hash, stage, job_id, at) VALUES (?, ?, ?, ?)")
      .Bind(hash, stage, job_id, report::UtcNow())
      .Run();
  db.Commit();
}

std::vector<std::string> BedTable::BedsPreparedBy(std::int64_t job_id) {
  Connection::Reading db = m_connection.Read();
  Statement& s =
      db->Prepare("SELECT stage, hash FROM bed_preparations WHERE job_id = ? ORDER BY rowid");
  s.Bind(job_id);
  std::vector<std::string> beds;
  while (s.Step()) beds.push_back(s.Text(0) + " " + s.Text(1));
  return beds;
}

std::vector<SlurmBedJob> BedTable::SlurmBedsWhere(const std::string& column,
                                                  const std::string& value) {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare(
      "SELECT hash, stage, slurm_id, state, error, job_id FROM slurm_beds "
      "WHERE " +
      column + " = ?");
  s.Bind(value);
  std::vector<SlurmBedJob> beds;
  while (s.Step()) beds.push_back({s.Text(0), s.Text(1), s.Int(2), s.Text(3), s.Text(4), s.Int(5)});
  return beds;
}

std::optional<SlurmBedJob> BedTable::GetSlurmBed(const std::string& hash) {
  std::vector<SlurmBedJob> beds = SlurmBedsWhere("hash", hash);
  if (beds.empty()) return std::nullopt;
  return beds.front();
}

std::vector<SlurmBedJob> BedTable::SlurmBedsInState(const std::string& state) {
  return SlurmBedsWhere("state", state);
}

void BedTable::PutSlurmBed(const SlurmBedJob& bed) {
  Connection::Writing db = m_connection.Write();
  db->Prepare(
        "INSERT OR REPLACE INTO slurm_beds (hash, stage, slurm_id, state, error, job_id, "
        "submitted_at) VALUES (?, ?, ?, ?, ?, ?, ?)")
      .Bind(bed.hash, bed.stage, bed.slurm_id, bed.state, bed.error, bed.job_id, report::UtcNow())
      .Run();
  db.Commit();
}

bool BedTable::PutBedFile(const BedFile& file, std::int64_t max_bytes_per_owner) {
  Connection::Writing db = m_connection.Write();
  Statement& known = db->Prepare("SELECT 1 FROM bed_files WHERE owner = ? AND sha256 = ?");
  known.Bind(file.owner, file.sha256);
  const bool had_it = known.Step();
  known.Run();
  if (had_it) return false;
  // Room for it: the owner's oldest files that no unfinished job imports make way, unless even
  // all of them would not make enough (then nothing is removed).
  Statement& files = db->Prepare(
      "SELECT sha256, LENGTH(data), sha256 IN (SELECT bed_file FROM jobs WHERE owner = ? AND "
      "state IN ('queued', 'preparing_bed', 'running')) FROM bed_files WHERE owner = ? "
      "ORDER BY created_at, rowid");  // (rowid: the order of one second's files)
  files.Bind(file.owner, file.owner);
  std::int64_t stored = 0, waited_for = 0;
  std::vector<std::pair<std::string, std::int64_t>> removable;  // oldest first
  while (files.Step()) {
    stored += files.Int(1);
    if (files.Int(2) != 0)
      waited_for += files.Int(1);
    else
      removable.emplace_back(files.Text(0), files.Int(1));
  }
  files.Run();
  const auto size = static_cast<std::int64_t>(file.data->size());
  if (waited_for + size > max_bytes_per_owner)
    throw BedFilesFull(file.owner + "'s bed files waiting for their jobs hold " +
                       std::to_string(waited_for) + " bytes; with these " + std::to_string(size) +
                       " they would pass " + std::to_string(max_bytes_per_owner) +
                       " (4 x max_bed_push_mb): wait for those jobs to end");
  for (const auto& [sha256, bytes] : removable) {
    if (stored + size <= max_bytes_per_owner) break;
    db->Prepare("DELETE FROM bed_files WHERE owner = ? AND sha256 = ?")
        .Bind(file.owner, sha256)
        .Run();
    m_bed_files_read.erase({file.owner, sha256});
    stored -= bytes;
  }
  Statement& s = db->Prepare(
      "INSERT INTO bed_files (owner, sha256, name, data, created_at) VALUES (?, ?, ?, ?, ?)");
  s.Bind(file.owner, file.sha256, file.name, Statement::Bytes{*file.data}, report::UtcNow());
  s.Run();
  db.Commit();
  return true;
}

std::optional<BedFile> BedTable::GetBedFile(const std::string& owner, const std::string& sha256) {
  constexpr std::size_t kBedFilesKept = 4;
  Connection::Reading db = m_connection.Read();
  if (const auto kept = m_bed_files_read.find({owner, sha256}); kept != m_bed_files_read.end())
    return kept->second;
  Statement& s = db->Prepare("SELECT name, data FROM bed_files WHERE owner = ? AND sha256 = ?");
  s.Bind(owner, sha256);
  if (!s.Step()) return std::nullopt;
  BedFile file{owner, sha256, s.Text(0), std::make_shared<const std::string>(s.Blob(1))};
  s.Run();
  if (Sha256Hex(*file.data) != sha256)
    throw DamagedData("bed file " + sha256 + " is damaged: it does not match its checksum");
  if (m_bed_files_read.size() >= kBedFilesKept) m_bed_files_read.erase(m_bed_files_read.begin());
  m_bed_files_read.emplace(std::pair{owner, sha256}, file);
  return file;
}

std::optional<PreparedBed> BedTable::Beds::Load(const std::string& hash) {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare("SELECT data FROM beds WHERE hash = ?");
  s.Bind(hash);
  if (!s.Step()) return std::nullopt;
  const std::string bytes = s.Blob(0);
  s.Run();
  return ParseBed(bytes, "bed " + hash + " in the database");
}

void BedTable::Beds::Save(const PreparedBed& bed) {
  const std::string bytes = SerializeBed(bed);
  Connection::Writing db = m_connection.Write();
  db->Prepare(
        "INSERT OR REPLACE INTO beds (hash, stage, beads, data, created_at) "
        "VALUES (?, ?, ?, ?, ?)")
      .Bind(bed.hash, bed.stage, static_cast<std::int64_t>(bed.beads.size()),
            Statement::Bytes{bytes}, report::UtcNow())
      .Run();
  db.Commit();
}

bool BedTable::Beds::Contains(const std::string& hash) {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare("SELECT 1 FROM beds WHERE hash = ?");
  s.Bind(hash);
  const bool found = s.Step();
  s.Run();
  return found;
}

}  // namespace dembuf::server
