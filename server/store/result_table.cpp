#include "store/result_table.h"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "dembuf/study/files/provenance.h"
#include "dembuf/study/files/run_output.h"
#include "store/fault_injection.h"

namespace dembuf::server {

namespace {

// Throws DamagedData naming `what` unless `data` has the checksum `sha256` (an empty one is
// no checksum: a row whose checksum was cleared is not taken on trust).
void CheckSum(const std::string& data, const std::string& sha256, const std::string& what) {
  if (sha256.empty() || Sha256Hex(data) != sha256)
    throw DamagedData(what + " is damaged: it does not match its checksum");
}

constexpr std::int64_t kHashPieceBytes = 1 << 20;

// The SHA-256 of a file read by `read_piece` from an offset, kHashPieceBytes at a time.
std::string FileSha256(const std::function<std::string(std::int64_t offset)>& read_piece) {
  Sha256Stream hash;
  for (std::int64_t offset = 0;; offset += kHashPieceBytes) {
    const std::string piece = read_piece(offset);
    hash.Add(piece);
    if (static_cast<std::int64_t>(piece.size()) < kHashPieceBytes) return hash.Hex();
  }
}

// A done job's peak plate force and P, as its row keeps them: numbers of its summary, else
// not known.
std::pair<std::optional<double>, std::optional<double>> PeakAndP(const std::string& summary_json) {
  const nlohmann::json summary = nlohmann::json::parse(summary_json, nullptr, false);
  auto number = [&](const char* key) -> std::optional<double> {
    if (!summary.is_object() || !summary.contains(key) || !summary[key].is_number())
      return std::nullopt;
    return summary[key].get<double>();
  };
  return {number("peak_plate_force_N"), number("P_N")};
}

}  // namespace

void ResultTable::AppendSeriesIn(Database& db, std::int64_t id, std::int64_t first,
                                 const std::vector<ImpactSample>& samples,
                                 std::int64_t chunk_samples) {
  const auto chunk = static_cast<std::size_t>(std::max<std::int64_t>(chunk_samples, 1));
  for (std::size_t begin = 0; begin < samples.size(); begin += chunk) {
    const std::size_t end = std::min(samples.size(), begin + chunk);
    const std::string bytes = report::PackSamples({samples.begin() + begin, samples.begin() + end});
    db.Prepare(
          "INSERT OR REPLACE INTO series_chunks (job_id, first_index, sample_count, data, "
          "sha256) VALUES (?, ?, ?, ?, ?)")
        .Bind(id, first + static_cast<std::int64_t>(begin), static_cast<std::int64_t>(end - begin),
              Statement::Bytes{bytes}, Sha256Hex(bytes))
        .Run();
  }
}

void ResultTable::AppendSeries(std::int64_t id, std::int64_t first,
                               const std::vector<ImpactSample>& samples) {
  Connection::Writing db = m_connection.Write();
  AppendSeriesIn(*db, id, first, samples, m_connection.options().chunk_samples);
  db.Commit();
}

std::vector<ImpactSample> ResultTable::ReadSeriesIn(Database& db, std::int64_t id,
                                                    std::int64_t from, std::int64_t max) {
  Statement& s = db.Prepare(
      "SELECT first_index, sample_count, data, sha256 FROM series_chunks "
      "WHERE job_id = ? AND first_index + sample_count > ? ORDER BY first_index");
  s.Bind(id, from);
  std::vector<ImpactSample> out;
  std::int64_t next = -1;  // where the next chunk must start
  auto damaged = [&](const std::string& why) {
    s.Bind();  // ends the statement before throwing
    return DamagedData("the series of job " + std::to_string(id) + " is damaged: " + why);
  };
  while (static_cast<std::int64_t>(out.size()) < max && s.Step()) {
    const std::int64_t first = s.Int(0), count = s.Int(1);
    const std::string bytes = s.Blob(2);
    if (next >= 0 && first != next)
      throw damaged("samples " + std::to_string(next) + " to " + std::to_string(first - 1) +
                    " are missing");
    if (first > from && next < 0)
      throw damaged("samples " + std::to_string(from) + " to " + std::to_string(first - 1) +
                    " are missing");
    if (Sha256Hex(bytes) != s.Text(3) ||
        bytes.size() != static_cast<std::size_t>(count) * report::kPackedSampleBytes)
      throw damaged("the chunk from sample " + std::to_string(first) +
                    " does not match its checksum");
    const std::vector<ImpactSample> chunk = report::UnpackSamples(bytes);
    for (std::int64_t k = std::max<std::int64_t>(from - first, 0);
         k < count && static_cast<std::int64_t>(out.size()) < max; ++k)
      out.push_back(chunk[k]);
    next = first + count;
  }
  s.Bind();  // reset: the statement may have stopped early
  return out;
}

std::vector<ImpactSample> ResultTable::ReadSeries(std::int64_t id, std::int64_t from,
                                                  std::int64_t max) {
  Connection::Reading db = m_connection.Read();
  return ReadSeriesIn(*db, id, from, max);
}

void ResultTable::FinishJob(std::int64_t id, JobState state, const std::string& error,
                            const JobResults& results) {
  FaultError("store-error-at-result-write");  // a failing database (the worker test)
  Connection::Writing db = m_connection.Write();
  AppendSeriesIn(*db, id, results.first_index, results.samples,
                 m_connection.options().chunk_samples);
  db->Prepare(
        "INSERT OR REPLACE INTO results (job_id, summary_json, sample_count, series, "
        "summary_sha256, series_sha256) VALUES (?, ?, ?, zeroblob(0), ?, ?)")
      .Bind(id, results.summary_json,
            results.first_index + static_cast<std::int64_t>(results.samples.size()),
            Sha256Hex(results.summary_json), Sha256Hex(""))
      .Run();
  PutJobFilesIn(*db, id, results.files);
  FaultPoint("kill-during-result-write");  // the series is written, the job not yet done
  // Its peak and P, for listings.
  const auto [peak, p] = state == JobState::kDone
                             ? PeakAndP(results.summary_json)
                             : std::pair<std::optional<double>, std::optional<double>>();
  db->Prepare(
        "UPDATE jobs SET state = ?, error = ?, finished_at = ?, peak_plate_force_N = ?, "
        "P_N = ? WHERE id = ?")
      .Bind(StateName(state), error, report::UtcNow(), peak, p, id)
      .Run();
  db.Commit();
}

bool CopyResultIn(Database& db, std::int64_t from, std::int64_t to) {
  Statement& done = db.Prepare(
      std::string("SELECT host, code_version, peak_plate_force_N, P_N FROM jobs WHERE ") +
      kJobWithStoredResult);
  done.Bind(from, from);
  if (!done.Step()) {
    done.Run();
    return false;
  }
  const std::string host = done.Text(0), code_version = done.Text(1);
  const std::optional<double> peak = done.Real(2), p = done.Real(3);
  done.Run();
  // The stored bytes and their checksums as they are: the same result, not a new one.
  db.Prepare(
        "INSERT INTO results (job_id, summary_json, sample_count, series, summary_sha256, "
        "series_sha256) SELECT ?, summary_json, sample_count, series, summary_sha256, "
        "series_sha256 FROM results WHERE job_id = ?")
      .Bind(to, from)
      .Run();
  db.Prepare(
        "INSERT INTO series_chunks (job_id, first_index, sample_count, data, sha256) SELECT ?, "
        "first_index, sample_count, data, sha256 FROM series_chunks WHERE job_id = ?")
      .Bind(to, from)
      .Run();
  db.Prepare(
        "INSERT INTO job_files (job_id, path, data, sha256) SELECT ?, path, data, sha256 FROM "
        "job_files WHERE job_id = ?")
      .Bind(to, from)
      .Run();
  const std::string now = report::UtcNow();
  db.Prepare(
        "UPDATE jobs SET state = 'done', started_at = ?, finished_at = ?, host = ?, "
        "code_version = ?, peak_plate_force_N = ?, P_N = ?, reused_from = ? WHERE id = ?")
      .Bind(now, now, host, code_version, peak, p, from, to)
      .Run();
  db.Prepare("INSERT INTO events (job_id, at, message) VALUES (?, ?, ?)")
      .Bind(to, now,
            "answered with job " + std::to_string(from) +
                "'s result (the same scene, seed, bed file and engine): not run again")
      .Run();
  return true;
}

void ResultTable::PutJobFiles(std::int64_t id, const std::vector<report::ResultFile>& files) {
  Connection::Writing db = m_connection.Write();
  PutJobFilesIn(*db, id, files);
  db.Commit();
}

void ResultTable::PutJobFilesIn(Database& db, std::int64_t id,
                                const std::vector<report::ResultFile>& files) {
  for (const report::ResultFile& file : files)
    db.Prepare("INSERT OR REPLACE INTO job_files (job_id, path, data, sha256) VALUES (?, ?, ?, ?)")
        .Bind(id, file.path, Database::AsBlob(file.data), Sha256Hex(file.data))
        .Run();
}

std::string ResultTable::ReadJobFilePieceIn(Database& db, std::int64_t id, const std::string& path,
                                            std::int64_t offset, std::int64_t max) {
  // substr counts bytes of a blob from 1.
  Statement& s =
      db.Prepare("SELECT substr(data, ? + 1, ?) FROM job_files WHERE job_id = ? AND path = ?");
  s.Bind(offset, max, id, path);
  std::string data = s.Step() ? s.Blob(0) : std::string();
  s.Run();
  return data;
}

std::optional<std::string> ResultTable::JobFileChecksumIn(Database& db, std::int64_t id,
                                                          const std::string& path) {
  Statement& s = db.Prepare("SELECT sha256 FROM job_files WHERE job_id = ? AND path = ?");
  s.Bind(id, path);
  if (!s.Step()) return std::nullopt;
  std::string sha = s.Text(0);
  s.Run();
  return sha;
}

void ResultTable::CheckJobFile(std::int64_t id, const std::string& path,
                               const std::optional<std::string>& sha256,
                               const std::function<std::string(std::int64_t offset)>& read_piece) {
  if (!sha256) return;  // no such file: nothing to serve
  if (sha256->empty() || FileSha256(read_piece) != *sha256)
    throw DamagedData("the result file " + path + " of job " + std::to_string(id) +
                      " is damaged: it does not match its checksum");
}

void ResultTable::AddMissingChecksums(Database& db) {
  // Results stored before checksums: taken as they are at the upgrade.
  std::vector<std::int64_t> ids;
  Statement& results = db.Prepare("SELECT job_id FROM results WHERE summary_sha256 = ''");
  results.Bind();
  while (results.Step()) ids.push_back(results.Int(0));
  for (std::int64_t id : ids) {
    Statement& row = db.Prepare("SELECT summary_json, series FROM results WHERE job_id = ?");
    row.Bind(id);
    row.Step();
    const std::string summary = row.Text(0), series = row.Blob(1);
    row.Run();
    db.Prepare("UPDATE results SET summary_sha256 = ?, series_sha256 = ? WHERE job_id = ?")
        .Bind(Sha256Hex(summary), Sha256Hex(series), id)
        .Run();
  }
  std::vector<std::pair<std::int64_t, std::string>> files;
  Statement& list = db.Prepare("SELECT job_id, path FROM job_files WHERE sha256 = ''");
  list.Bind();
  while (list.Step()) files.push_back({list.Int(0), list.Text(1)});
  // (No structured bindings: the lambdas capture the names, which clang 14 refuses for them.)
  for (const auto& file : files) {
    const std::int64_t id = file.first;
    const std::string& path = file.second;
    db.Prepare("UPDATE job_files SET sha256 = ? WHERE job_id = ? AND path = ?")
        .Bind(FileSha256([&](std::int64_t offset) {
                return ReadJobFilePieceIn(db, id, path, offset, kHashPieceBytes);
              }),
              id, path)
        .Run();
  }
}

void ResultTable::AddMissingPeaks(Database& db) {
  // Only from a summary that matches its checksum: a damaged one leaves them not known.
  std::vector<std::pair<std::int64_t, std::string>> done;
  Statement& s = db.Prepare(
      "SELECT j.id, r.summary_json, r.summary_sha256 FROM jobs j JOIN results r "
      "ON r.job_id = j.id WHERE j.state = 'done'");
  s.Bind();
  while (s.Step()) {
    const std::string summary = s.Text(1);
    try {
      CheckSum(summary, s.Text(2), "the summary of job " + std::to_string(s.Int(0)));
      done.push_back({s.Int(0), summary});
    } catch (const DamagedData&) {
    }
  }
  for (const auto& [id, summary] : done) {
    const auto [peak, p] = PeakAndP(summary);
    db.Prepare("UPDATE jobs SET peak_plate_force_N = ?, P_N = ? WHERE id = ?")
        .Bind(peak, p, id)
        .Run();
  }
}

void ResultTable::CheckResults(Database& db, CheckReport& report) {
  std::vector<std::int64_t> ids;
  Statement& results = db.Prepare("SELECT job_id FROM results ORDER BY job_id");
  results.Bind();
  while (results.Step()) ids.push_back(results.Int(0));
  for (std::int64_t id : ids) {
    Statement& row = db.Prepare(
        "SELECT summary_json, summary_sha256, series, series_sha256, sample_count FROM results "
        "WHERE job_id = ?");
    row.Bind(id);
    row.Step();
    const std::string summary = row.Text(0), summary_sha = row.Text(1), series = row.Blob(2),
                      series_sha = row.Text(3);
    const std::int64_t count = row.Int(4);
    row.Run();
    ++report.summaries;
    try {
      CheckSum(summary, summary_sha, "the summary of job " + std::to_string(id));
      CheckSum(series, series_sha, "the series of job " + std::to_string(id));
      if (series.empty()) {
        // Every chunk, read as FetchSeries reads it: checksums, order, the count.
        std::int64_t read = 0;
        for (std::int64_t from = 0; from < count; from += read) {
          read = static_cast<std::int64_t>(ReadSeriesIn(db, id, from, 1 << 16).size());
          if (read == 0) break;
        }
        Statement& chunks = db.Prepare(
            "SELECT count(*), IFNULL(sum(sample_count), 0) FROM series_chunks WHERE job_id = ?");
        chunks.Bind(id);
        chunks.Step();
        report.series_chunks += chunks.Int(0);
        const std::int64_t stored = chunks.Int(1);
        chunks.Run();
        if (stored != count)
          throw DamagedData("the series of job " + std::to_string(id) +
                            " is damaged: " + std::to_string(stored) + " of its " +
                            std::to_string(count) + " samples are stored");
      }
    } catch (const DamagedData& e) {
      report.problems.push_back(e.what());
    }
  }
  std::vector<std::pair<std::int64_t, std::string>> files;
  Statement& list = db.Prepare("SELECT job_id, path FROM job_files ORDER BY job_id, path");
  list.Bind();
  while (list.Step()) files.push_back({list.Int(0), list.Text(1)});
  for (const auto& file : files) {
    const std::int64_t id = file.first;
    const std::string& path = file.second;
    ++report.files;
    try {
      CheckJobFile(id, path, JobFileChecksumIn(db, id, path), [&](std::int64_t offset) {
        return ReadJobFilePieceIn(db, id, path, offset, kHashPieceBytes);
      });
    } catch (const DamagedData& e) {
      report.problems.push_back(e.what());
    }
  }
}

std::vector<JobFileInfo> ResultTable::JobFiles(std::int64_t id) {
  Connection::Reading db = m_connection.Read();
  Statement& s =
      db->Prepare("SELECT path, length(data) FROM job_files WHERE job_id = ? ORDER BY path");
  s.Bind(id);
  std::vector<JobFileInfo> files;
  while (s.Step()) files.push_back({s.Text(0), s.Int(1)});
  return files;
}

std::string ResultTable::ReadJobFile(std::int64_t id, const std::string& path, std::int64_t offset,
                                     std::int64_t max) {
  if (offset == 0) {
    // The lock is taken for one piece at a time: a large file is checked without holding the
    // store for every other request meanwhile.
    const std::optional<std::string> sha256 = JobFileChecksumIn(*m_connection.Read(), id, path);
    CheckJobFile(id, path, sha256, [&](std::int64_t from) {
      return ReadJobFilePieceIn(*m_connection.Read(), id, path, from, kHashPieceBytes);
    });
  }
  return ReadJobFilePieceIn(*m_connection.Read(), id, path, offset, max);
}

std::optional<JobResults> ResultTable::GetResults(std::int64_t id) {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare(
      "SELECT summary_json, sample_count, series, summary_sha256, series_sha256 FROM results "
      "WHERE job_id = ?");
  s.Bind(id);
  if (!s.Step()) return std::nullopt;
  JobResults results{s.Text(0), {}, 0, {}};
  const std::int64_t count = s.Int(1);
  const std::string legacy = s.Blob(2);  // a whole series, from before chunks
  const std::string summary_sha = s.Text(3), series_sha = s.Text(4);
  s.Run();
  CheckSum(results.summary_json, summary_sha, "the summary of job " + std::to_string(id));
  CheckSum(legacy, series_sha, "the series of job " + std::to_string(id));
  if (!legacy.empty()) {
    results.samples = report::UnpackSamples(legacy);
    return results;
  }
  results.samples = ReadSeriesIn(*db, id, 0, count);
  if (static_cast<std::int64_t>(results.samples.size()) != count)
    throw DamagedData("the series of job " + std::to_string(id) +
                      " is damaged: " + std::to_string(results.samples.size()) + " of its " +
                      std::to_string(count) + " samples are stored");
  return results;
}

std::string ResultTable::Summary(std::int64_t id) {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare("SELECT summary_json, summary_sha256 FROM results WHERE job_id = ?");
  s.Bind(id);
  if (!s.Step()) return "";
  std::string summary = s.Text(0);
  const std::string sha = s.Text(1);
  s.Run();
  CheckSum(summary, sha, "the summary of job " + std::to_string(id));
  return summary;
}

std::vector<ImpactSample> ResultTable::ReadResultSeries(std::int64_t id, std::int64_t from,
                                                        std::int64_t max) {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare("SELECT length(series) FROM results WHERE job_id = ?");
  s.Bind(id);
  const bool whole = s.Step() && s.Int(0) > 0;
  s.Run();
  if (!whole) return ReadSeriesIn(*db, id, from, max);
  // A series stored whole, by a daemon from before chunks: read it all, keep the part asked.
  Statement& blob = db->Prepare("SELECT series, series_sha256 FROM results WHERE job_id = ?");
  blob.Bind(id);
  blob.Step();
  const std::string bytes = blob.Blob(0), sha = blob.Text(1);
  blob.Run();
  CheckSum(bytes, sha, "the series of job " + std::to_string(id));
  const std::vector<ImpactSample> all = report::UnpackSamples(bytes);
  const auto size = static_cast<std::int64_t>(all.size());
  const std::int64_t begin = std::clamp<std::int64_t>(from, 0, size);
  const std::int64_t end =
      std::clamp<std::int64_t>(begin + std::max<std::int64_t>(max, 0), 0, size);
  return {all.begin() + begin, all.begin() + end};
}

std::int64_t ResultTable::ResultSeriesLength(std::int64_t id) {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare("SELECT sample_count FROM results WHERE job_id = ?");
  s.Bind(id);
  const std::int64_t count = s.Step() ? s.Int(0) : 0;
  s.Run();
  return count;
}

std::vector<SweepJobResult> ResultTable::SweepResults(std::int64_t sweep_id) {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare(
      "SELECT j.id, j.sweep_index, j.sweep_values_json, j.state, j.error, "
      "IFNULL(r.summary_json, ''), IFNULL(r.summary_sha256, ?) FROM jobs j "
      "LEFT JOIN results r ON r.job_id = j.id WHERE j.sweep_id = ? ORDER BY j.sweep_index, j.id");
  s.Bind(Sha256Hex(""), sweep_id);
  std::vector<SweepJobResult> jobs;
  while (s.Step()) {
    SweepJobResult job;
    job.id = s.Int(0);
    job.sweep_index = static_cast<int>(s.Int(1));
    job.sweep_values = nlohmann::json::parse(s.Text(2)).get<std::vector<std::string>>();
    job.state = ParseState(s.Text(3)).value_or(JobState::kFailed);
    job.error = s.Text(4);
    job.summary_json = s.Text(5);
    // A damaged summary is left out, the job's point with it, and says so.
    try {
      CheckSum(job.summary_json, s.Text(6), "the summary of job " + std::to_string(job.id));
    } catch (const DamagedData& e) {
      job.summary_json.clear();
      job.error = e.what();
    }
    jobs.push_back(std::move(job));
  }
  return jobs;
}

std::int64_t ResultTable::SeriesLength(std::int64_t id) {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare(
      "SELECT IFNULL(MAX(first_index + sample_count), 0) FROM series_chunks WHERE job_id = ?");
  s.Bind(id);
  s.Step();
  const std::int64_t length = s.Int(0);
  s.Run();
  return length;
}

}  // namespace dembuf::server
