#include "remote/remote.h"

#include <grpcpp/grpcpp.h>
#include <unistd.h>

#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <thread>

#include "api_json.h"
#include "dembuf/study/bed/bed.h"
#include "dembuf/study/bed/bed_formats.h"
#include "dembuf/study/files/run_output.h"
#include "dembuf/study/files/snapshot_report.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/sweep/sweep_plan.h"
#include "dembuf/study/sweep/sweep_report.h"
#include "dembuf/study/text/text_limits.h"
#include "dembuf/v1/dembuf.grpc.pb.h"
#include "local/plots.h"
#include "local/scene_input.h"
#include "remote/remote_json.h"
#include "terminal/exit_codes.h"
#include "terminal/interrupts.h"
#include "terminal/progress.h"

namespace dembuf::cli {

namespace fs = std::filesystem;

namespace {

// A server's text as printed in tables and on the terminal: what is not UTF-8, control
// characters (a C1 byte starts a terminal escape) and bidirectional controls shown as '?'.
std::string Shown(const std::string& text) {
  return PrintableText(text);
}

constexpr const char* kDefaultServer = "127.0.0.1:50051";

// The largest answer taken from a server: a list of 100,000 jobs is about 50 MB; a series
// longer than FetchResults carries (65,536 samples, 3.5 MB) comes in FetchSeries' pieces.
constexpr int kMaxAnswerBytes = 128 << 20;
// The longest series a client takes from a server: a job's series is at most the daemon's
// quota_samples (a million by default); this is a hundred times that (some 10 GB of CSV).
constexpr std::int64_t kMaxSeriesSamples = 100'000'000;
// The most bytes of result files a client takes for one job: the daemon's quota_output_mb
// (1024 by default) sixteen times.
constexpr std::int64_t kMaxResultFilesBytes = std::int64_t{16} << 30;

std::unique_ptr<v1::Dembuf::Stub> Connect(const Remote& remote) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(kMaxAnswerBytes);
  // No compressed answers: this gRPC inflates a message whole before it compares it with the
  // limit above, so a server could send 300 KB that becomes 300 MB. Identity only; and as
  // gRPC refuses a compressed answer only by its header, it is told to inflate none at all.
  args.SetInt(GRPC_COMPRESSION_CHANNEL_ENABLED_ALGORITHMS_BITSET, 1);
  args.SetInt(GRPC_ARG_ENABLE_PER_MESSAGE_DECOMPRESSION, 0);
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (!remote.tls_ca.empty()) {
    std::ifstream in(remote.tls_ca);
    if (!in) throw std::runtime_error("--tls-ca: cannot read " + remote.tls_ca);
    std::ostringstream pem;
    pem << in.rdbuf();
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = pem.str();
    credentials = grpc::SslCredentials(ssl);
  }
  return v1::Dembuf::NewStub(grpc::CreateCustomChannel(remote.address, credentials, args));
}

// Every call carries the user's token (if any) and, unless it streams, a deadline.
void Prepare(grpc::ClientContext& context, const Remote& remote, int seconds = 60) {
  if (seconds > 0)
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
  if (!remote.token.empty()) context.AddMetadata("authorization", "Bearer " + remote.token);
}

const char* StatusName(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::CANCELLED:
      return "cancelled";
    case grpc::StatusCode::UNIMPLEMENTED:
      return "not implemented (is it a dembufd of another version?)";
    case grpc::StatusCode::ABORTED:
      return "aborted";
    case grpc::StatusCode::OUT_OF_RANGE:
      return "out of range";
    case grpc::StatusCode::DATA_LOSS:
      return "data loss";
    default:
      return "an unknown error";
  }
}

// One line per failure, with the server's message (which names the field at fault).
int Report(const Remote& remote, const grpc::Status& status) {
  // The message is the server's text: printed, never obeyed (an escape sequence shows as '?').
  const std::string message = Shown(status.error_message());
  // This client's refusal of a compressed answer (dembuf's own servers send none).
  if (status.error_message().rfind("Compression algorithm", 0) == 0) {
    std::fprintf(stderr,
                 "dembuf: the server at %s sent a compressed answer, which dembuf does not take "
                 "(%s)\n",
                 remote.address.c_str(), message.c_str());
    return kExitRuntime;
  }
  switch (status.error_code()) {
    case grpc::StatusCode::INVALID_ARGUMENT:
      std::fprintf(stderr, "dembuf: the server refused the request: %s\n", message.c_str());
      return kExitBadInput;
    case grpc::StatusCode::UNAVAILABLE:
      std::fprintf(stderr,
                   "dembuf: cannot reach dembufd at %s (%s); start it, or point --server or "
                   "DEMBUF_SERVER at it\n",
                   remote.address.c_str(), message.c_str());
      return kExitRuntime;
    case grpc::StatusCode::UNAUTHENTICATED:
      std::fprintf(stderr, "dembuf: not allowed in: %s\n", message.c_str());
      return kExitRuntime;
    case grpc::StatusCode::PERMISSION_DENIED:
      std::fprintf(stderr, "dembuf: not yours: %s\n", message.c_str());
      return kExitRuntime;
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      // This client's refusal of an answer larger than it takes ("... vs. its limit").
      if (status.error_message().find("larger than max") != std::string::npos &&
          status.error_message().find("vs. " + std::to_string(kMaxAnswerBytes)) !=
              std::string::npos) {
        std::fprintf(stderr, "dembuf: the server at %s sent an answer larger than %d MB: %s\n",
                     remote.address.c_str(), kMaxAnswerBytes >> 20, message.c_str());
        return kExitRuntime;
      }
      // gRPC's own refusal of a request larger than the server reads.
      if (status.error_message().find("larger than max") != std::string::npos) {
        std::fprintf(stderr,
                     "dembuf: the request is larger than this server accepts (max_request_kb): "
                     "%s\n",
                     message.c_str());
        return kExitBadInput;
      }
      // A user's quota on the server (queued jobs, stored results): their own to free.
      if (status.error_details().rfind("quota=", 0) == 0) {
        std::fprintf(stderr, "dembuf: over your quota on the server: %s\n", message.c_str());
        return kExitRuntime;
      }
      // A job past the server's limits names the field to change (bad input); a full queue
      // or disk is worth trying again later.
      if (status.error_details().rfind("field=", 0) == 0) {
        std::fprintf(stderr, "dembuf: refused by the server's limits: %s\n", message.c_str());
        return kExitBadInput;
      }
      std::fprintf(stderr, "dembuf: the server is full: %s\n", message.c_str());
      return kExitRuntime;
    case grpc::StatusCode::NOT_FOUND:
      std::fprintf(stderr, "dembuf: not found: %s\n", message.c_str());
      return kExitBadInput;
    case grpc::StatusCode::FAILED_PRECONDITION:
      std::fprintf(stderr, "dembuf: not now: %s\n", message.c_str());
      return kExitRuntime;
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      std::fprintf(stderr, "dembuf: dembufd at %s did not answer in time (%s)\n",
                   remote.address.c_str(), message.c_str());
      return kExitRuntime;
    case grpc::StatusCode::INTERNAL:
      std::fprintf(stderr, "dembuf: %s\n", message.c_str());
      return kExitRuntime;
    default:
      std::fprintf(stderr, "dembuf: dembufd answered %s: %s\n", StatusName(status.error_code()),
                   message.c_str());
      return kExitRuntime;
  }
}

// JSON a server sent, within the bounds of JSON from outside (text_limits.h); `what` names it.
// Throws std::runtime_error naming the server.
nlohmann::json ServerJson(const Remote& remote, const std::string& text, const std::string& what) {
  try {
    return ParseBoundedJson(text, what);
  } catch (const InputLimitError& e) {
    throw std::runtime_error("the server at " + remote.address + " sent " + e.what());
  }
}

// The JSON of a job or a sweep a server sent (its summary or aggregates within the bounds of
// JSON from outside).
template <class View>
nlohmann::json FromServer(const Remote& remote, View view) {
  try {
    return view();
  } catch (const InputLimitError& e) {
    throw std::runtime_error("the server at " + remote.address + " sent " + e.what());
  }
}
nlohmann::json ServerJobJson(const Remote& remote, const v1::Job& job, bool details) {
  return FromServer(remote, [&] { return api::JobJson(job, details); });
}
nlohmann::json ServerSweepJson(const Remote& remote, const v1::Sweep& sweep) {
  return FromServer(remote, [&] { return api::SweepJson(sweep, true); });
}

bool Ended(v1::JobState s) {
  return s == v1::JOB_STATE_DONE || s == v1::JOB_STATE_FAILED || s == v1::JOB_STATE_CANCELLED;
}

// ", about 1:23 left" from when a job started (UTC, ISO 8601 as the server writes it) and the
// fraction it has done; "" while too little is done to tell, or for a time that does not parse.
std::string TimeLeft(const std::string& started_at, double fraction) {
  std::tm tm{};
  std::istringstream in(started_at);
  in >> std::get_time(&tm, "%Y-%m-%dT%H:%M:%S");
  if (in.fail() || !(fraction > 0.02 && fraction < 1.0)) return "";
  const double elapsed = std::difftime(std::time(nullptr), timegm(&tm));
  if (elapsed <= 0.0) return "";
  const long left = std::lround(elapsed * (1.0 - fraction) / fraction);
  char text[48];
  std::snprintf(text, sizeof text, ", about %ld:%02ld left", left / 60, left % 60);
  return text;
}

// One exit code per job state for status, watch and fetch: 0 done (or still going), 3 failed,
// 4 cancelled.
int ExitOfJob(v1::JobState s) {
  if (s == v1::JOB_STATE_FAILED) return kExitFailed;
  if (s == v1::JOB_STATE_CANCELLED) return kExitCancelled;
  return kExitDone;
}

void PrintWarnings(const google::protobuf::RepeatedPtrField<std::string>& warnings) {
  for (const std::string& w : warnings) {
    std::fprintf(stderr, "dembuf: warning: %s\n", Shown(w).c_str());
  }
}

// What a command tells people besides its result (on stderr; not with -q).
__attribute__((format(printf, 1, 2))) void Note(const char* format, ...) {
  if (GetVerbosity() == Verbosity::kQuiet) return;
  std::va_list args;
  va_start(args, format);
  std::vfprintf(stderr, format, args);
  va_end(args);
}

// Sends a bed to the server in pieces (PushBed); the first piece says what it is.
grpc::Status PushBed(const Remote& remote, const std::string& kind, const std::string& name,
                     const std::string& scene_toml, const std::string& data,
                     v1::PushBedResponse* response) {
  constexpr std::size_t kPieceBytes = 256 << 10;  // as the server takes them (bed_push.h)
  const auto stub = Connect(remote);
  grpc::ClientContext context;
  Prepare(context, remote, 600);
  std::unique_ptr<grpc::ClientWriter<v1::BedPiece>> writer = stub->PushBed(&context, response);
  v1::BedPiece piece;
  piece.set_kind(kind);
  piece.set_name(name);
  piece.set_size(static_cast<std::int64_t>(data.size()));
  piece.set_scene_toml(scene_toml);
  if (kind == "file") piece.set_owner(remote.owner);
  std::size_t offset = 0;
  do {
    piece.set_data(data.substr(offset, kPieceBytes));
    offset += piece.data().size();
    if (!writer->Write(piece)) break;  // the server ended the call: Finish says why
    piece.Clear();
  } while (offset < data.size());
  writer->WritesDone();
  return writer->Finish();
}

// A file's name as the server keeps it: letters, digits, '.', '_' and '-' (others become '_').
std::string PlainFileName(const std::filesystem::path& path) {
  std::string name = path.filename().string().substr(0, 100);
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-') c = '_';
  if (name.empty() || name.front() == '.') name.insert(0, "bed");
  return name;
}

// The file a scene imports (bed.import), sent to the server: the request names its SHA-256
// (SceneSpec.bed_file) instead of a path on this machine; none when the scene imports none.
// Throws SceneError for a file this client cannot read.
grpc::Status SendBedFile(const Remote& remote, const RemoteScene& remote_scene,
                         std::string* sha256) {
  Scene scene;
  try {
    scene = ResolveScene(remote_scene.scene_file, remote_scene.preset, remote_scene.overrides,
                         remote_scene.accuracy);
  } catch (const SceneError& e) {
    if (e.field() == "bed.import") throw;
    return grpc::Status::OK;  // the server resolves the scene and names what is wrong with it
  }
  if (scene.bed.import.empty()) return grpc::Status::OK;
  std::string data;
  try {
    data = ReadBoundedFile(scene.bed.import, kMaxBedFileBytes, "bed file");
  } catch (const InputLimitError& e) {
    throw SceneError("bed.import", e.what());
  }
  v1::PushBedResponse response;
  const grpc::Status status =
      PushBed(remote, "file", PlainFileName(scene.bed.import), "", data, &response);
  if (!status.ok()) return status;
  Note("sent %s (%zu bytes) with the request\n", scene.bed.import.c_str(), data.size());
  *sha256 = response.hash();
  return status;
}

// The request's scene; a bed file it imports is sent first.
grpc::Status MakeSceneSpec(const Remote& remote, const RemoteScene& scene, v1::SceneSpec* out) {
  v1::SceneSpec& spec = *out;
  RequireJoinedAssignments("--set", scene.overrides, scene.scene_file);
  if (grpc::Status s = SendBedFile(remote, scene, spec.mutable_bed_file()); !s.ok()) return s;
  spec.set_preset(scene.preset);
  spec.set_accuracy(scene.accuracy);
  if (!scene.scene_file.empty()) {
    std::ifstream in(scene.scene_file);
    if (!in) throw std::runtime_error("cannot read scene file " + scene.scene_file);
    std::ostringstream text;
    text << in.rdbuf();
    spec.set_scene_toml(text.str());
  }
  for (const auto& s : scene.overrides) spec.add_set(s);
  return grpc::Status::OK;
}

ImpactSample FromProto(const v1::ForceSample& s) {
  return {s.t_s(),      s.plate_force_n(), s.wall_force_z_n(),
          s.proj_z_m(), s.proj_vz_m_s(),   s.proj_force_z_n()};
}

std::string Percent(double fraction) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%3.0f%%", 100 * std::clamp(fraction, 0.0, 1.0));
  return buf;
}

// Eight-level bars of the last `width` values, scaled to their largest.
std::string Sparkline(const std::vector<double>& values, std::size_t width) {
  static const char* const kBars[] = {"▁", "▂", "▃", "▄", "▅", "▆", "▇", "█"};
  if (values.empty()) return "";
  const std::size_t columns = std::min(width, values.size());
  const double per_column = static_cast<double>(values.size()) / columns;
  double top = 0.0;
  for (double v : values) top = std::max(top, v);
  std::string line;
  for (std::size_t c = 0; c < columns; ++c) {
    double column_max = 0.0;
    const auto begin = static_cast<std::size_t>(c * per_column);
    const auto end = std::max(begin + 1, static_cast<std::size_t>((c + 1) * per_column));
    for (std::size_t k = begin; k < end && k < values.size(); ++k)
      column_max = std::max(column_max, values[k]);
    const int level = top > 0 ? static_cast<int>(std::lround(7 * column_max / top)) : 0;
    line += kBars[std::clamp(level, 0, 7)];
  }
  return line;
}

// The plate force of a watched job, for its chart, in bounded memory however long the job or
// however many samples a server sends: at most 2 x kColumns values, each the largest of
// `stride` samples; when they are all taken, neighbours merge and the stride doubles.
class ForceTrace {
 public:
  static constexpr std::size_t kColumns = 1024;

  void Add(double force) {
    m_last = force;
    if (m_taken == 0)
      m_values.push_back(force);
    else
      m_values.back() = std::max(m_values.back(), force);
    if (++m_taken < m_stride) return;
    m_taken = 0;
    if (m_values.size() < 2 * kColumns) return;
    for (std::size_t k = 0; k < kColumns; ++k)
      m_values[k] = std::max(m_values[2 * k], m_values[2 * k + 1]);
    m_values.resize(kColumns);
    m_stride *= 2;
  }
  const std::vector<double>& values() const { return m_values; }
  double last() const { return m_last; }

 private:
  std::vector<double> m_values;
  std::uint64_t m_stride = 1;
  std::uint64_t m_taken = 0;  ///< samples in the last value so far
  double m_last = 0.0;
};

// A job's name as one safe folder name: whatever the server sends, the files stay inside the
// folder the user chose (no separators, no "..", no leading dot, printable).
std::string SafeFolderName(const std::string& name, std::int64_t id) {
  std::string safe;
  for (char c : name) {
    const bool ok = std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' ||
                    c == '=' || c == '.' || c == '+';
    safe += ok ? c : '_';
  }
  while (!safe.empty() && safe.front() == '.') safe.erase(safe.begin());
  if (safe.empty()) safe = "job" + std::to_string(id);
  return safe.substr(0, 200);
}

// A sweep axis as the server described it, for the terminal.
std::string AxisText(const v1::SweepAxis& axis) {
  std::string text = axis.field() + " = ";
  for (int k = 0; k < axis.values_size(); ++k) text += (k ? "," : "") + axis.values(k);
  return Shown(text);
}

// A long series (one FetchResults leaves out) streamed into `csv` piece by piece, checked
// against the length the server announced.
grpc::Status StreamSeries(v1::Dembuf::Stub& stub, const Remote& remote, std::int64_t id,
                          std::int64_t length, report::SampleCsvWriter& csv) {
  grpc::ClientContext context;
  Prepare(context, remote, 3600);
  v1::FetchSeriesRequest request;
  request.set_id(id);
  auto reader = stub.FetchSeries(&context, request);
  v1::SeriesChunk chunk;
  std::int64_t written = 0;
  while (reader->Read(&chunk)) {
    if (chunk.first_index() != written || chunk.total() != length ||
        chunk.samples_size() > length - written) {
      context.TryCancel();
      return grpc::Status(grpc::StatusCode::DATA_LOSS,
                          "the server at " + remote.address + " sent job " + std::to_string(id) +
                              "'s series out of order or longer than its " +
                              std::to_string(length) + " samples");
    }
    for (const auto& s : chunk.samples()) csv.Write(FromProto(s));
    written += chunk.samples_size();
  }
  const grpc::Status status = reader->Finish();
  if (status.ok() && written != length)
    return grpc::Status(grpc::StatusCode::DATA_LOSS, "the server at " + remote.address + " sent " +
                                                         std::to_string(written) + " of job " +
                                                         std::to_string(id) + "'s " +
                                                         std::to_string(length) + " samples");
  return status;
}

grpc::Status WriteJobFiles(v1::Dembuf::Stub& stub, const Remote& remote,
                           const v1::FetchResultsResponse& result, const fs::path& dir) {
  const v1::Job& job = result.job();
  // What the server announces is checked before anything is sized or written by it.
  if (result.series_length() < result.samples_size() || result.series_length() > kMaxSeriesSamples)
    return grpc::Status(grpc::StatusCode::DATA_LOSS,
                        "the server at " + remote.address + " announced " +
                            std::to_string(result.series_length()) + " samples for job " +
                            std::to_string(job.id()) + "; a client takes at most " +
                            std::to_string(kMaxSeriesSamples) + " (and " +
                            std::to_string(result.samples_size()) + " came with the answer)");
  fs::create_directories(dir);
  report::SampleCsvWriter csv(dir / report::run_files::kPlateForce);
  if (result.series_length() > result.samples_size()) {
    if (grpc::Status s = StreamSeries(stub, remote, job.id(), result.series_length(), csv); !s.ok())
      return s;
  } else {
    for (const auto& s : result.samples()) csv.Write(FromProto(s));
  }
  csv.Commit();
  report::WriteFileAtomically(dir / report::run_files::kScene, job.scene_toml());
  // The job as `dembuf status --json` shows it, but for what the folder holds as files of
  // their own (summary.json, scene.toml).
  nlohmann::json record = ServerJobJson(remote, job, true);
  const nlohmann::json summary = std::move(record["summary"]);  // (parsed once, checked)
  record.erase("summary");
  record.erase("scene_toml");
  report::WriteFileAtomically(dir / "job.json", record.dump(2) + "\n");
  if (job.state() == v1::JOB_STATE_DONE) {
    report::WriteFileAtomically(dir / report::run_files::kSummary, job.summary_json());
    report::WriteFileAtomically(dir / report::run_files::kLog,
                                report::RunLogText(summary));  // as a local run's
  } else if (job.state() == v1::JOB_STATE_CANCELLED) {
    // As a local run stopped before its end: what it had computed, marked incomplete.
    report::WriteFileAtomically(
        dir / report::run_files::kIncomplete,
        nlohmann::json{{"cancelled", true}, {"complete", false}, {"note", job.error()}}.dump(2) +
            "\n");
  } else {
    report::WriteFileAtomically(
        dir / report::run_files::kFailure,
        nlohmann::json{{"state", api::StateText(job.state())}, {"error", job.error()}}.dump(2) +
            "\n");
  }
  return grpc::Status::OK;
}

}  // namespace

bool ServerGiven(const std::string& flag) {
  const char* env = std::getenv("DEMBUF_SERVER");
  return !flag.empty() || (env && *env);
}

std::string ServerAddress(const std::string& flag) {
  if (!flag.empty()) return flag;
  if (const char* env = std::getenv("DEMBUF_SERVER"); env && *env) return env;
  return kDefaultServer;
}

namespace {

// A random id for one submission, 32 hex digits: the daemon files a request once however
// often it arrives with it.
std::string NewRequestId() {
  std::random_device random;  // the system's generator
  std::string id;
  for (int k = 0; k < 4; ++k) {
    char word[9];
    std::snprintf(word, sizeof word, "%08x", random());
    id += word;
  }
  return id;
}

// Sends a submission and, while the daemon cannot be reached or its answer does not come in
// time (a reply lost on the way), sends it again with the same request id, twice at most.
template <class Call>
grpc::Status SubmitWithRetries(const Remote& remote, Call&& call) {
  grpc::Status status;
  for (int attempt = 0; attempt < 3; ++attempt) {
    if (attempt > 0) std::this_thread::sleep_for(std::chrono::milliseconds(500 * attempt));
    grpc::ClientContext context;
    Prepare(context, remote);
    status = call(context);
    if (status.error_code() != grpc::StatusCode::UNAVAILABLE &&
        status.error_code() != grpc::StatusCode::DEADLINE_EXCEEDED)
      break;
  }
  return status;
}

}  // namespace

int RemoteSubmit(const Remote& remote, const RemoteScene& scene, const SubmitOptions& options) {
  v1::SubmitJobRequest request;
  if (grpc::Status s = MakeSceneSpec(remote, scene, request.mutable_scene()); !s.ok())
    return Report(remote, s);
  request.set_name(options.name);
  request.set_owner(remote.owner);
  request.set_command_line(remote.command_line.substr(0, kMaxCommandLineBytes));
  request.set_request_id(NewRequestId());
  request.set_notify(options.notify);
  request.set_no_reuse(options.no_reuse);
  v1::SubmitJobResponse response;
  const auto stub = Connect(remote);
  const grpc::Status status = SubmitWithRetries(remote, [&](grpc::ClientContext& context) {
    return stub->SubmitJob(&context, request, &response);
  });
  if (!status.ok()) return Report(remote, status);
  PrintWarnings(response.warnings());
  std::printf("%lld\n", static_cast<long long>(response.job().id()));
  if (options.no_reuse && response.job().reused_from() != 0) {
    // (A server that does not do what was asked: the result was not computed for this job.)
    std::fprintf(stderr,
                 "dembuf: the server at %s answered job %lld with job %lld's stored result, "
                 "though --no-reuse asked for a run\n",
                 remote.address.c_str(), static_cast<long long>(response.job().id()),
                 static_cast<long long>(response.job().reused_from()));
    return kExitRuntime;
  }
  if (response.job().reused_from() != 0)
    Note(
        "job %lld on %s: answered at once with job %lld's stored result (the same scene, seed, "
        "bed file and engine; --no-reuse runs it)\n",
        static_cast<long long>(response.job().id()), remote.address.c_str(),
        static_cast<long long>(response.job().reused_from()));
  else
    Note("job %lld queued on %s; watch it with: dembuf watch %lld\n",
         static_cast<long long>(response.job().id()), remote.address.c_str(),
         static_cast<long long>(response.job().id()));
  return 0;
}

int RemoteSweep(const Remote& remote, const RemoteScene& scene,
                const std::vector<std::string>& vary, const std::string& table, int seeds,
                const SubmitOptions& options, bool json) {
  v1::SubmitSweepRequest request;
  if (!table.empty()) {  // read here, checked by the daemon
    const SweepTable points = ReadSweepTableFile(table);
    for (const std::string& field : points.fields) request.mutable_table()->add_fields(field);
    for (const auto& row : points.rows) {
      v1::SweepRow* out = request.mutable_table()->add_rows();
      for (const std::string& value : row) out->add_values(value);
    }
  }
  RequireJoinedAssignments("--vary", vary, scene.scene_file);
  if (grpc::Status s = MakeSceneSpec(remote, scene, request.mutable_base()); !s.ok())
    return Report(remote, s);
  for (const std::string& spec : vary) {
    const SweepSpec parts = SplitSweepSpec(spec);  // checked by the daemon
    auto* axis = request.add_axes();
    axis->set_field(parts.field);
    axis->set_range(parts.range);
    for (const auto& v : parts.values) axis->add_values(v);
  }
  request.set_seeds(seeds);
  request.set_notify(options.notify);
  request.set_no_reuse(options.no_reuse);
  request.set_name(options.name);
  request.set_owner(remote.owner);
  request.set_command_line(remote.command_line.substr(0, kMaxCommandLineBytes));
  request.set_request_id(NewRequestId());
  v1::SubmitSweepResponse response;
  const auto stub = Connect(remote);
  const grpc::Status status = SubmitWithRetries(remote, [&](grpc::ClientContext& context) {
    return stub->SubmitSweep(&context, request, &response);
  });
  if (!status.ok()) return Report(remote, status);
  const v1::Sweep& sweep = response.sweep();
  if (response.job_ids_size() == 0) {
    std::fprintf(stderr, "dembuf: the server at %s answered sweep %lld with no jobs\n",
                 remote.address.c_str(), static_cast<long long>(sweep.id()));
    return kExitRuntime;
  }
  PrintWarnings(response.warnings());
  if (json) {
    const std::vector<std::int64_t> job_ids(response.job_ids().begin(), response.job_ids().end());
    std::printf("%s\n",
                nlohmann::json{{"sweep", api::SweepJson(sweep, false)}, {"job_ids", job_ids}}
                    .dump(2)
                    .c_str());
    return 0;
  }
  std::printf("%lld\n", static_cast<long long>(sweep.id()));
  const auto done = sweep.jobs_by_state().find("done");
  const int reused = done == sweep.jobs_by_state().end() ? 0 : done->second;
  Note("sweep %lld: %d jobs on %s (jobs %lld to %lld)%s\n", static_cast<long long>(sweep.id()),
       sweep.jobs_total(), remote.address.c_str(), static_cast<long long>(response.job_ids(0)),
       static_cast<long long>(response.job_ids(response.job_ids_size() - 1)),
       reused == 0 ? ", queued"
                   : (", " + std::to_string(reused) +
                      " answered at once from stored results of the same scenes (--no-reuse "
                      "runs them)")
                         .c_str());
  for (const auto& axis : sweep.axes()) Note("  %s\n", AxisText(axis).c_str());
  Note(
      "follow it with: dembuf status --sweep %lld; fetch it with: dembuf fetch --sweep %lld "
      "--out DIR\n",
      static_cast<long long>(sweep.id()), static_cast<long long>(sweep.id()));
  return 0;
}

int RemoteList(const Remote& remote, const ListOptions& options) {
  auto stub = Connect(remote);
  grpc::ClientContext context;
  Prepare(context, remote);
  if (options.sweeps) {
    v1::ListSweepsRequest request;
    request.set_owner(options.owner);
    request.set_limit(options.limit);
    v1::ListSweepsResponse response;
    const grpc::Status status = stub->ListSweeps(&context, request, &response);
    if (!status.ok()) return Report(remote, status);
    if (options.json) {
      nlohmann::json sweeps = nlohmann::json::array();
      for (const auto& s : response.sweeps()) sweeps.push_back(api::SweepJson(s, false));
      std::printf("%s\n", nlohmann::json{{"sweeps", sweeps}}.dump(2).c_str());
      return 0;
    }
    std::printf("%6s  %-12s %-20s %6s %6s %6s %6s  %s\n", "SWEEP", "OWNER", "NAME", "JOBS", "DONE",
                "FAILED", "BEDS", "CREATED");
    for (const auto& s : response.sweeps()) {
      auto count = [&](const char* state) {
        auto it = s.jobs_by_state().find(state);
        return it == s.jobs_by_state().end() ? 0 : it->second;
      };
      std::printf("%6lld  %-12s %-20s %6d %6d %6d %6d  %s\n", static_cast<long long>(s.id()),
                  Shown(s.owner()).c_str(), Shown(s.name()).c_str(), s.jobs_total(), count("done"),
                  count("failed"), s.beds_prepared(), Shown(s.created_at()).c_str());
    }
    return 0;
  }
  v1::ListJobsRequest request;
  if (!options.state.empty()) {
    v1::JobState state = v1::JOB_STATE_UNSPECIFIED;
    for (int s = v1::JOB_STATE_QUEUED; s <= v1::JOB_STATE_CANCELLED; ++s)
      if (options.state == api::StateText(static_cast<v1::JobState>(s)))
        state = static_cast<v1::JobState>(s);
    if (state == v1::JOB_STATE_UNSPECIFIED) {
      std::fprintf(stderr,
                   "dembuf: --state %s: use queued, preparing_bed, running, done, failed or "
                   "cancelled\n",
                   options.state.c_str());
      return kExitBadInput;
    }
    request.set_state(state);
  }
  request.set_owner(options.owner);
  request.set_sweep_id(options.sweep);
  request.set_limit(options.limit);
  v1::ListJobsResponse response;
  const grpc::Status status = stub->ListJobs(&context, request, &response);
  if (!status.ok()) return Report(remote, status);
  if (options.json) {
    nlohmann::json jobs = nlohmann::json::array();
    for (const auto& j : response.jobs()) jobs.push_back(ServerJobJson(remote, j, false));
    std::printf("%s\n", nlohmann::json{{"jobs", jobs}}.dump(2).c_str());
    return 0;
  }
  std::printf("%6s  %-13s %-12s %6s  %-34s %-18s %s\n", "JOB", "STATE", "OWNER", "SWEEP", "NAME",
              "PROGRESS", "CREATED");
  for (const auto& j : response.jobs()) {
    const std::string progress = j.progress().stage() + " " + Percent(j.progress().fraction());
    std::printf("%6lld  %-13s %-12s %6s  %-34s %-18s %s\n", static_cast<long long>(j.id()),
                api::StateText(j.state()).c_str(), Shown(j.owner()).c_str(),
                j.sweep_id() ? std::to_string(j.sweep_id()).c_str() : "-", Shown(j.name()).c_str(),
                progress.c_str(), j.created_at().c_str());
  }
  return 0;
}

int RemoteStatus(const Remote& remote, std::int64_t id, bool sweep, bool json) {
  auto stub = Connect(remote);
  grpc::ClientContext context;
  Prepare(context, remote);
  if (sweep) {
    v1::GetSweepRequest request;
    request.set_id(id);
    request.set_aggregates(true);
    v1::Sweep s;
    const grpc::Status status = stub->GetSweep(&context, request, &s);
    if (!status.ok()) return Report(remote, status);
    if (json) {
      std::printf("%s\n", ServerSweepJson(remote, s).dump(2).c_str());
      return 0;
    }
    std::printf("sweep %lld  %s  owner %s  created %s\n", static_cast<long long>(s.id()),
                Shown(s.name()).c_str(), Shown(s.owner()).c_str(), Shown(s.created_at()).c_str());
    for (const auto& axis : s.axes()) std::printf("  %s\n", AxisText(axis).c_str());
    std::printf("jobs: %d", s.jobs_total());
    for (const auto& [state, count] :
         std::map<std::string, int>(s.jobs_by_state().begin(), s.jobs_by_state().end()))
      std::printf(", %s %d", Shown(state).c_str(), count);
    std::printf("\nbeds prepared: %d\n", s.beds_prepared());
    // Hc as the server computed it: each part checked before it is read.
    const nlohmann::json view = ServerSweepJson(remote, s);
    const auto hc = view.find("critical_thickness");
    if (hc != view.end() && hc->is_object()) {
      const auto hc_m = hc->find("Hc_m"), reached = hc->find("reached"), note = hc->find("note");
      if (reached != hc->end() && *reached == true && hc_m != hc->end() && hc_m->is_number())
        std::printf("critical thickness Hc = %.2f cm\n", 100 * hc_m->get<double>());
      else if (note != hc->end() && note->is_string())
        std::printf("%s\n", Shown(note->get<std::string>()).c_str());
    }
    return 0;
  }
  v1::GetJobRequest request;
  request.set_id(id);
  v1::Job j;
  const grpc::Status status = stub->GetJob(&context, request, &j);
  if (!status.ok()) return Report(remote, status);
  if (json) {
    std::printf("%s\n", ServerJobJson(remote, j, true).dump(2).c_str());
    return ExitOfJob(j.state());
  }
  std::printf("job %lld  %s  (%s)\n", static_cast<long long>(j.id()), Shown(j.name()).c_str(),
              api::StateText(j.state()).c_str());
  std::printf("owner %s, sweep %s, attempts %d\n", Shown(j.owner()).c_str(),
              j.sweep_id() ? std::to_string(j.sweep_id()).c_str() : "-", j.attempts());
  std::printf("created %s, started %s, finished %s\n", Shown(j.created_at()).c_str(),
              j.started_at().empty() ? "-" : Shown(j.started_at()).c_str(),
              j.finished_at().empty() ? "-" : Shown(j.finished_at()).c_str());
  // Progress while the job lives (one fraction over its bed stages and impact, and the time
  // left it implies); an ended job shows its summary (or reason) below instead.
  if (!Ended(j.state()))
    std::printf("progress: %s %s%s, t = %.4f ms, peak plate force so far %.5g N\n",
                Shown(j.progress().stage()).c_str(), Percent(j.progress().fraction()).c_str(),
                TimeLeft(j.started_at(), j.progress().fraction()).c_str(),
                j.progress().sim_time_s() * 1e3, j.progress().peak_plate_force_n());
  std::printf("scene %s, bed %s\n", Shown(j.scene_hash()).c_str(),
              j.bed_hash().empty() ? "(none)" : Shown(j.bed_hash()).c_str());
  if (j.reused_from() != 0)
    std::printf(
        "reused: job %lld's stored result (the same scene, seed, bed file and engine), not run "
        "again; its provenance is that job's (--no-reuse runs it)\n",
        static_cast<long long>(j.reused_from()));
  if (j.slurm_job_id() != 0)
    std::printf(
        "Slurm job %lld%s%s%s\n", static_cast<long long>(j.slurm_job_id()),
        j.has_slurm_array_task() ? ("_" + std::to_string(j.slurm_array_task())).c_str() : "",
        j.host().empty() ? "" : " on ", Shown(j.host()).c_str());
  for (const auto& bed : j.beds_prepared()) std::printf("prepared bed: %s\n", Shown(bed).c_str());
  if (j.files_size() > 0) {
    std::int64_t bytes = 0;
    for (const auto& file : j.files()) bytes += file.size();
    std::printf("result files: %d (%.3g MB; dembuf fetch writes them)\n", j.files_size(),
                bytes / 1e6);
  }
  if (!j.error().empty()) std::printf("note: %s\n", Shown(j.error()).c_str());
  if (!j.summary_json().empty()) {
    const nlohmann::json s =
        ServerJson(remote, j.summary_json(), "job " + std::to_string(j.id()) + "'s summary_json");
    auto force = [&](const char* key) {
      char text[32] = "-";
      if (s.contains(key) && s[key].is_number())
        std::snprintf(text, sizeof text, "%.5g N", s[key].get<double>());
      return std::string(text);
    };
    std::printf(
        "P = %.5g N, Pa = %s, Pb = %s, lambda = %.2f%%, crater %.3f cm, H = %.3f cm, C0 = "
        "%.3f\n",
        s.value("P_N", 0.0), force("Pa_N").c_str(), force("Pb_N").c_str(),
        100 * s.value("lambda", 0.0), 100 * s.value("crater_depth_m", 0.0),
        100 * report::MeasuredThickness(s), s.value("C0", 0.0));
  }
  return ExitOfJob(j.state());
}

// The finished job's numbers as its summary gives them (the stream's peak is that of the
// samples it carried, at the output interval).
void PrintFinalNumbers(v1::Dembuf::Stub& stub, const Remote& remote, std::int64_t id) {
  grpc::ClientContext context;
  Prepare(context, remote, 0);
  v1::GetJobRequest request;
  request.set_id(id);
  v1::Job job;
  if (!stub.GetJob(&context, request, &job).ok() || job.summary_json().empty()) return;
  nlohmann::json s;
  try {
    s = ParseBoundedJson(job.summary_json(), "the summary");
  } catch (const InputLimitError&) {
    return;  // the numbers are a courtesy; fetch and status say what is wrong with them
  }
  if (!s.is_object()) return;
  auto number = [&](const char* key) {
    return s.contains(key) && s[key].is_number() ? s[key].get<double>() : std::nan("");
  };
  std::printf("job %lld done: peak plate force %.5g N, P = %.5g N, lambda = %.2f%%\n",
              static_cast<long long>(id), number("peak_plate_force_N"), number("P_N"),
              100 * number("lambda"));
}

int RemoteWatchSweep(const Remote& remote, std::int64_t id) {
  auto stub = Connect(remote);
  CatchInterrupts();
  const double interval_s = std::max(0.2, PlainProgressInterval() / 5);
  std::string last;
  while (true) {
    grpc::ClientContext context;
    Prepare(context, remote);
    v1::GetSweepRequest request;
    request.set_id(id);
    v1::Sweep s;
    if (const grpc::Status status = stub->GetSweep(&context, request, &s); !status.ok())
      return Report(remote, status);
    // The server's counts, checked before they are added up.
    std::map<std::string, int> counts;
    long long ended = 0, total = s.jobs_total();
    for (const auto& [state, count] : s.jobs_by_state()) {
      bool known = false;
      for (int k = v1::JOB_STATE_QUEUED; k <= v1::JOB_STATE_CANCELLED; ++k)
        known = known || state == api::StateText(static_cast<v1::JobState>(k));
      if (count < 0 || count > 1000000 || !known) {
        std::fprintf(stderr, "dembuf: the server sent a bad count of sweep %lld's jobs\n",
                     static_cast<long long>(id));
        return kExitRuntime;
      }
      counts[state] = count;
      if (state == "done" || state == "failed" || state == "cancelled") ended += count;
    }
    std::string line = "sweep " + std::to_string(id) + ": " + std::to_string(ended) + " of " +
                       std::to_string(total) + " jobs ended";
    for (const auto& [state, count] : counts) line += ", " + state + " " + std::to_string(count);
    if (line != last) std::printf("%s\n", line.c_str());
    std::fflush(stdout);
    last = line;
    long long counted = 0;
    for (const auto& entry : counts) counted += entry.second;
    if (total < 1 || total > 1000000 || counted != total) {
      std::fprintf(stderr,
                   "dembuf: the server sent sweep %lld with %lld jobs in all but %lld by state\n",
                   static_cast<long long>(id), total, counted);
      return kExitRuntime;
    }
    if (ended >= total)
      return counts["failed"] > 0 ? kExitFailed : counts["cancelled"] > 0 ? kExitCancelled : 0;
    if (Interrupted()) return InterruptedExit();
    std::this_thread::sleep_for(std::chrono::duration<double>(interval_s));
  }
}

int RemoteWatch(const Remote& remote, std::int64_t id, bool csv, std::int64_t from_index) {
  auto stub = Connect(remote);
  grpc::ClientContext context;
  Prepare(context, remote, 0);
  v1::WatchJobRequest request;
  request.set_id(id);
  request.set_from_index(from_index);
  auto reader = stub->WatchJob(&context, request);
  const bool tty = !csv && isatty(fileno(stdout));
  // plate_force.csv's columns and cells, between the sample's index and the job's state.
  if (csv) std::printf("index,%s,state\n", report::SampleCsvColumns().c_str());
  ForceTrace forces;
  v1::WatchJobResponse message;
  v1::JobState state = v1::JOB_STATE_UNSPECIFIED;
  std::int64_t received = 0;
  std::string last_line, last_printed;
  double last_t = 0.0;
  auto last_print = std::chrono::steady_clock::time_point{};
  while (reader->Read(&message)) {
    state = message.state();
    // The samples in order, each once: a server's answer is checked, not believed.
    if (message.first_index() != from_index + received) {
      context.TryCancel();
      std::fprintf(stderr,
                   "dembuf: the server at %s sent job %lld's samples from %lld where %lld were "
                   "due\n",
                   remote.address.c_str(), static_cast<long long>(id),
                   static_cast<long long>(message.first_index()),
                   static_cast<long long>(from_index + received));
      return kExitRuntime;
    }
    for (int k = 0; k < message.samples_size(); ++k) {
      const auto& s = message.samples(k);
      forces.Add(s.plate_force_n());
      last_t = s.t_s();
      if (csv)
        std::printf("%lld,%s,%s\n", static_cast<long long>(message.first_index() + k),
                    report::SampleCsvCells(FromProto(s)).c_str(), api::StateText(state).c_str());
    }
    received += message.samples_size();
    const double force = forces.last();
    // The stage only where it says more than the state; an ended job's time is its last
    // sample's.
    const std::string stage = message.progress().stage() == api::StateText(state)
                                  ? ""
                                  : Shown(message.progress().stage());
    const double t = message.progress().sim_time_s() > 0 ? message.progress().sim_time_s() : last_t;
    char line[256];
    std::snprintf(
        line, sizeof line, "job %lld %-13s %-14s t = %8.3f ms  F = %9.4g N  peak %9.4g N  %s",
        static_cast<long long>(id), api::StateText(state).c_str(), stage.c_str(), t * 1e3, force,
        message.progress().peak_plate_force_n(), Percent(message.progress().fraction()).c_str());
    if (tty) {
      // Two lines, redrawn in place: the numbers and a chart of F(t) so far.
      std::printf("\r\033[K%s\n\033[K%s\033[1A\r", line, Sparkline(forces.values(), 72).c_str());
      std::fflush(stdout);
    } else if (!csv && line != last_printed &&
               std::chrono::steady_clock::now() - last_print > std::chrono::seconds(1)) {
      std::printf("%s\n", line);  // a log: a line a second at most, and only when it changed
      std::fflush(stdout);
      last_print = std::chrono::steady_clock::now();
      last_printed = line;
    }
    last_line = line;
    if (csv) std::fflush(stdout);
  }
  const grpc::Status status = reader->Finish();
  if (tty) std::printf("\n\n");
  if (!status.ok()) return Report(remote, status);
  if (!csv && !tty && last_line != last_printed) std::printf("%s\n", last_line.c_str());
  if (!csv && state == v1::JOB_STATE_DONE) PrintFinalNumbers(*stub, remote, id);
  Note("job %lld %s; %lld samples received\n", static_cast<long long>(id),
       api::StateText(state).c_str(), static_cast<long long>(received));
  return Ended(state) ? ExitOfJob(state) : kExitRuntime;
}

// A job's result files (snapshots), streamed piece by piece into `dir`. The server's answers
// are not trusted: only the names the API defines (report::IsResultFileName), pieces in order,
// sizes as announced and within bounds. A refusal is DATA_LOSS with one sentence naming the
// server and the file; nothing is written under another name.
grpc::Status FetchJobResultFiles(v1::Dembuf::Stub& stub, const Remote& remote, const v1::Job& job,
                                 const fs::path& dir) {
  if (job.files_size() == 0) return grpc::Status::OK;
  constexpr std::int64_t kMaxFileBytes = std::int64_t{1} << 34;  // 16 GiB
  // The files the job lists, with their sizes: what comes must be exactly that.
  std::map<std::string, std::int64_t> listed;
  std::int64_t listed_bytes = 0;
  for (const v1::ResultFileInfo& file : job.files()) {
    listed[file.path()] = file.size();
    if (file.size() < 0 || file.size() > kMaxResultFilesBytes - listed_bytes)
      return grpc::Status(grpc::StatusCode::DATA_LOSS,
                          "the server at " + remote.address + " lists more than " +
                              std::to_string(kMaxResultFilesBytes >> 30) +
                              " GiB of result files for job " + std::to_string(job.id()) +
                              "; nothing of them was written");
    listed_bytes += file.size();
  }
  grpc::ClientContext context;
  Prepare(context, remote, 3600);
  v1::FetchFilesRequest request;
  request.set_id(job.id());
  auto reader = stub.FetchFiles(&context, request);
  v1::FileChunk chunk;
  std::string path;
  std::int64_t size = 0, written = 0;
  std::ofstream out;
  auto bad = [&](const std::string& file, const std::string& why) {
    context.TryCancel();
    std::string shown = file.substr(0, 80);
    for (char& c : shown)
      if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) c = '?';
    return grpc::Status(grpc::StatusCode::DATA_LOSS,
                        "the server at " + remote.address + " sent a bad result file \"" + shown +
                            "\" for job " + std::to_string(job.id()) + ": " + why +
                            "; nothing of it was written");
  };
  auto close = [&]() -> bool {
    out.close();
    if (!out || written != size) return false;
    fs::rename(dir / (path + ".partial"), dir / path);
    return true;
  };
  try {
    while (reader->Read(&chunk)) {
      if (chunk.path() != path || !out.is_open()) {
        if (out.is_open() && !close()) return bad(path, "cut short");
        if (!report::IsResultFileName(chunk.path()))
          return bad(chunk.path(), "not a name the API defines");
        if (chunk.path() <= path) return bad(chunk.path(), "out of order");
        if (chunk.size() < 0 || chunk.size() > kMaxFileBytes)
          return bad(chunk.path(),
                     "a size of " + std::to_string(chunk.size()) + " bytes (at most 16 GiB)");
        if (const auto it = listed.find(chunk.path());
            it == listed.end() || it->second != chunk.size())
          return bad(chunk.path(), "not the size the job lists, or a file it does not list");
        path = chunk.path();
        size = chunk.size();
        written = 0;
        fs::create_directories((dir / path).parent_path());
        out.open(dir / (path + ".partial"), std::ios::binary | std::ios::trunc);
        if (!out) throw std::runtime_error("cannot write " + (dir / path).string());
      }
      if (chunk.offset() != written || chunk.size() != size ||
          static_cast<std::int64_t>(chunk.data().size()) > size - written)
        return bad(path, "pieces out of order or longer than announced");
      out.write(chunk.data().data(), static_cast<std::streamsize>(chunk.data().size()));
      written += static_cast<std::int64_t>(chunk.data().size());
    }
  } catch (const fs::filesystem_error& e) {
    context.TryCancel();
    throw std::runtime_error("cannot write " + (dir / path).string() + ": " + e.code().message());
  }
  const grpc::Status status = reader->Finish();
  if (!status.ok()) return status;
  if (out.is_open() && !close()) return bad(path, "cut short");
  return grpc::Status::OK;
}

namespace {

// A finished job's results (its summary and series' start), within ten minutes.
grpc::Status FetchJobResults(v1::Dembuf::Stub& stub, const Remote& remote, std::int64_t id,
                             v1::FetchResultsResponse* result) {
  grpc::ClientContext context;
  Prepare(context, remote, 600);
  v1::FetchResultsRequest request;
  request.set_id(id);
  return stub.FetchResults(&context, request, result);
}

// A job's values go into sweep.csv, points.csv and the table: each must be one of its axis's
// values, which were checked as values of the field.
// The job's values of the axes into `run`, as a local sweep's reports write them; false (and
// `run` unchanged) when they are not the axes' values. A second job of the same index (a
// hostile server's) replaces the first's values.
bool TakeValuesOfAxes(const v1::Job& job, const std::vector<SweepAxis>& axes, SweepRunReport& run) {
  if (job.sweep_values_size() != static_cast<int>(axes.size())) return false;
  for (int a = 0; a < job.sweep_values_size(); ++a) {
    const std::vector<std::string>& allowed = axes[static_cast<std::size_t>(a)].values;
    if (std::find(allowed.begin(), allowed.end(), job.sweep_values(a)) == allowed.end())
      return false;
  }
  run.values.clear();
  for (std::size_t a = 0; a < axes.size(); ++a)
    run.values.push_back(CanonicalSweepValue(axes[a].field, job.sweep_values(static_cast<int>(a))));
  return true;
}

// dembuf fetch ID: the job's folder.
int FetchJob(v1::Dembuf::Stub& stub, const Remote& remote, std::int64_t id, const fs::path& dir,
             bool plots) {
  v1::FetchResultsResponse result;
  const grpc::Status status = FetchJobResults(stub, remote, id, &result);
  if (!status.ok()) return Report(remote, status);
  if (const grpc::Status series = WriteJobFiles(stub, remote, result, dir); !series.ok())
    return Report(remote, series);
  if (const grpc::Status files = FetchJobResultFiles(stub, remote, result.job(), dir); !files.ok())
    return Report(remote, files);
  std::printf("job %lld (%s): wrote %s\n", static_cast<long long>(id),
              api::StateText(result.job().state()).c_str(), dir.c_str());
  if (plots && result.job().state() == v1::JOB_STATE_DONE) PlotIfPossible(dir);
  return ExitOfJob(result.job().state());
}

// dembuf fetch --sweep ID: a run folder per finished job, and the sweep's tables.
int FetchSweep(v1::Dembuf::Stub& stub, const Remote& remote, std::int64_t id, const fs::path& dir,
               bool plots, bool long_table) {
  v1::Sweep s;
  {
    grpc::ClientContext context;
    Prepare(context, remote);
    v1::GetSweepRequest request;
    request.set_id(id);
    const grpc::Status status = stub.GetSweep(&context, request, &s);
    if (!status.ok()) return Report(remote, status);
  }
  v1::ListJobsResponse jobs;
  {
    grpc::ClientContext context;
    Prepare(context, remote);
    v1::ListJobsRequest request;
    request.set_sweep_id(id);
    request.set_limit(100000);
    const grpc::Status status = stub.ListJobs(&context, request, &jobs);
    if (!status.ok()) return Report(remote, status);
  }
  // The server's names become file contents and plot labels here: only scene fields (and the
  // values are checked as numbers of the field) are taken.
  std::vector<SweepAxis> axes;
  try {
    for (const auto& a : s.axes())
      axes.push_back(MakeSweepAxis(
          a.field(), std::vector<std::string>(a.values().begin(), a.values().end()), ""));
  } catch (const SceneError& e) {
    std::fprintf(stderr,
                 "dembuf: the server sent a sweep axis that is no scene field, or a value that "
                 "is not one of it: %s\n",
                 e.what());
    return kExitRuntime;
  }
  // A count from the server is checked before anything is sized by it.
  constexpr int kMaxSweepJobs = 1000000;  // the daemon's max_sweep_jobs at most
  if (s.jobs_total() < jobs.jobs_size() || s.jobs_total() > kMaxSweepJobs) {
    std::fprintf(stderr,
                 "dembuf: the server at %s sent a bad sweep %lld: jobs_total = %d, with %d jobs "
                 "listed (must be that many to %d)\n",
                 remote.address.c_str(), static_cast<long long>(id), s.jobs_total(),
                 jobs.jobs_size(), kMaxSweepJobs);
    return kExitRuntime;
  }
  std::vector<SweepRunReport> runs(static_cast<std::size_t>(s.jobs_total()));
  int pending = 0;
  for (const v1::Job& job : jobs.jobs()) {
    const auto index = static_cast<std::size_t>(job.sweep_index());
    if (index >= runs.size()) continue;
    SweepRunReport& run = runs[index];
    run.name = SafeFolderName(job.name(), job.id());
    run.id = job.id();
    if (!TakeValuesOfAxes(job, axes, run)) {
      std::fprintf(stderr,
                   "dembuf: the server at %s sent job %lld of sweep %lld with values that are "
                   "not its sweep's\n",
                   remote.address.c_str(), static_cast<long long>(job.id()),
                   static_cast<long long>(id));
      return kExitRuntime;
    }
    if (!Ended(job.state())) {
      run.state = api::StateText(job.state());
      run.error = std::string("still ") + api::StateText(job.state());
      ++pending;
      continue;
    }
    v1::FetchResultsResponse result;
    const grpc::Status status = FetchJobResults(stub, remote, job.id(), &result);
    if (!status.ok()) return Report(remote, status);
    const fs::path run_dir = dir / "runs" / SafeFolderName(job.name(), job.id());
    if (const grpc::Status series = WriteJobFiles(stub, remote, result, run_dir); !series.ok())
      return Report(remote, series);
    if (const grpc::Status files = FetchJobResultFiles(stub, remote, result.job(), run_dir);
        !files.ok())
      return Report(remote, files);
    run.ok = result.job().state() == v1::JOB_STATE_DONE;
    run.state = api::StateText(result.job().state());
    run.error = result.job().error();
    if (run.ok)
      run.summary = ServerJson(remote, result.job().summary_json(),
                               "job " + std::to_string(job.id()) + "'s summary_json");
  }
  const nlohmann::json extra = {{"sweep", s.id()},
                                {"server", remote.address},
                                {"beds_prepared", s.beds_prepared()},
                                {"pending", pending}};
  const nlohmann::json summary = WriteSweepReport(dir, axes, runs, extra, stdout);
  std::printf("sweep %lld: wrote %s (%d jobs, %d failed, %d not finished)\n",
              static_cast<long long>(id), dir.c_str(), s.jobs_total(),
              summary["failed"].get<int>() - pending, pending);
  if (long_table)
    std::printf("wrote %s: %zu samples\n", (dir / sweep_files::kLong).c_str(),
                WriteSweepLongTable(dir, axes, runs));
  if (plots) PlotIfPossible(dir);
  return pending == 0 && summary["failed"].get<int>() == 0 ? 0 : kExitFailed;
}

}  // namespace

int RemoteFetch(const Remote& remote, std::int64_t id, bool sweep, const std::string& out_dir,
                bool plots, bool force, bool long_table) {
  if (long_table && !sweep) {
    std::fprintf(stderr, "dembuf: --long writes a sweep's samples as one table: add --sweep\n");
    return kExitBadInput;
  }
  auto stub = Connect(remote);
  const fs::path dir = out_dir;
  std::error_code error;
  if (fs::exists(dir) && !fs::is_empty(dir, error)) {
    if (!force) {
      std::fprintf(stderr,
                   "dembuf: %s already exists and is not empty; choose another --out, or pass "
                   "--force to replace an earlier fetch's files\n",
                   dir.c_str());
      return kExitBadInput;
    }
    // Only what a fetch writes: a job's files, or a sweep's tables, plots and runs.
    report::RemoveRunOutputs(dir);
    for (const char* name : {sweep_files::kTable, sweep_files::kPoints, sweep_files::kRuns})
      fs::remove_all(dir / name, error);
    for (const auto& entry : fs::directory_iterator(dir, error))
      if (entry.path().filename().string().rfind("sweep", 0) == 0) fs::remove(entry.path(), error);
  }
  return sweep ? FetchSweep(*stub, remote, id, dir, plots, long_table)
               : FetchJob(*stub, remote, id, dir, plots);
}

int RemotePushBeds(const Remote& remote, const RemoteScene& remote_scene,
                   const std::string& bed_cache) {
  const Scene scene = ResolveScene(remote_scene.scene_file, remote_scene.preset,
                                   remote_scene.overrides, remote_scene.accuracy);
  if (!scene.bed.import.empty())
    throw SceneError("bed.import",
                     "an imported bed is not pushed: submit the job, which sends its file");
  const std::vector<BedStage> stages = BedStagesOf(scene);
  if (stages.empty()) throw SceneError("bed.thickness_m", "0: this scene has no bed to push");
  const std::string scene_toml = report::SceneText(scene);
  int pushed = 0;
  for (const BedStage& stage : stages) {
    const std::filesystem::path path = std::filesystem::path(bed_cache) / (stage.hash + ".bed");
    if (!std::filesystem::exists(path)) {
      Note("%s bed %s: not in %s\n", stage.stage.c_str(), stage.hash.c_str(), bed_cache.c_str());
      continue;
    }
    const std::string data = ReadBoundedFile(path.string(), kMaxBedFileBytes, "bed");
    CheckPreparedBed(ParseBed(data, path.string()), scene);  // as the server will
    v1::PushBedResponse response;
    const grpc::Status status = PushBed(remote, "prepared", "", scene_toml, data, &response);
    if (!status.ok()) return Report(remote, status);
    std::printf("%s bed %s (%lld beads): %s\n", Shown(response.stage()).c_str(),
                Shown(response.hash()).c_str(), static_cast<long long>(response.beads()),
                response.had_it() ? "the server had it" : "pushed");
    ++pushed;
  }
  if (pushed == 0) {
    std::fprintf(stderr,
                 "dembuf: none of this scene's beds is in %s; prepare them first (dembuf "
                 "prepare-bed with the same scene)\n",
                 bed_cache.c_str());
    return kExitBadInput;
  }
  return 0;
}

namespace {

// A Cancel or Delete request that names job `id`, or sweep `id`.
template <class Request>
Request NamingJobOrSweep(std::int64_t id, bool sweep) {
  Request request;
  if (sweep) {
    request.set_sweep_id(id);
  } else {
    request.set_job_id(id);
  }
  return request;
}

}  // namespace

int RemoteCancel(const Remote& remote, std::int64_t id, bool sweep) {
  const auto request = NamingJobOrSweep<v1::CancelRequest>(id, sweep);
  v1::CancelResponse response;
  grpc::ClientContext context;
  Prepare(context, remote);
  const grpc::Status status = Connect(remote)->Cancel(&context, request, &response);
  if (!status.ok()) return Report(remote, status);
  std::printf("cancelled %d job(s)\n", response.cancelled());
  return 0;
}

int RemoteServerInfo(const Remote& remote, bool json) {
  v1::ServerInfoResponse info;
  grpc::ClientContext context;
  Prepare(context, remote, 10);
  const grpc::Status status = Connect(remote)->ServerInfo(&context, {}, &info);
  if (!status.ok()) return Report(remote, status);
  if (json) {
    std::printf("%s\n", ServerInfoJson(info, remote.address).dump(2).c_str());
    return 0;
  }
  std::printf("dembufd %s at %s (host %s, up since %s)\n", Shown(info.version()).c_str(),
              remote.address.c_str(), Shown(info.host()).c_str(), Shown(info.started_at()).c_str());
  if (info.executor() == "slurm")
    std::printf(
        "jobs run on a Slurm cluster, %d CPUs each; running %d, queued %d of %d, "
        "database %s\n",
        info.threads_per_job(), info.running(), info.queue_depth(), info.queue_limit(),
        Shown(info.database()).c_str());
  else
    std::printf("workers %d x %d threads, running %d, queued %d of %d%s%s\n", info.workers(),
                info.threads_per_job(), info.running(), info.queue_depth(), info.queue_limit(),
                info.database().empty() ? "" : ", database ", Shown(info.database()).c_str());
  if (info.notify())
    std::printf(
        "notifications: submit --notify and sweep --notify post the end to the lab's chat\n");
  // The caller's share, against the per-user quotas (counts whole, bytes in MB to 0.01).
  auto of = [](double used, double quota, const char* format) {
    char used_text[32], quota_text[32];
    std::snprintf(used_text, sizeof used_text, format, used);
    std::snprintf(quota_text, sizeof quota_text, format, quota);
    return std::string(used_text) + (quota > 0 ? " of " + std::string(quota_text) : " (no quota)");
  };
  std::printf("yours: %s queued jobs, %s of stored results\n",
              of(info.queued_jobs(), info.quota_queued_jobs(), "%.0f").c_str(),
              of(info.stored_bytes() / 1e6, info.quota_stored_bytes() / 1e6, "%.2f MB").c_str());
  return 0;
}

int RemoteDelete(const Remote& remote, std::int64_t id, bool sweep) {
  const auto request = NamingJobOrSweep<v1::DeleteRequest>(id, sweep);
  v1::DeleteResponse response;
  grpc::ClientContext context;
  Prepare(context, remote);
  const grpc::Status status = Connect(remote)->Delete(&context, request, &response);
  if (!status.ok()) return Report(remote, status);
  std::printf("deleted %d job(s); %.2f MB of results freed\n", response.deleted(),
              response.freed_bytes() / 1e6);
  return 0;
}

}  // namespace dembuf::cli
