// The daemon's pieces without the network: the API's scene covers every scene field and
// carries values exactly; the store migrates, keeps results exactly and refuses to touch a
// database that is not its own.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include "access/access_policy.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/presets.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/text/sha256.h"
#include "doors/admission.h"
#include "doors/scene_request.h"
#include "store/store.h"

namespace dembuf::server {
namespace {

namespace fs = std::filesystem;
using google::protobuf::Descriptor;
using google::protobuf::FieldDescriptor;

// The proto field at a dotted path ("bed.thickness_m"), or null.
const FieldDescriptor* ProtoField(const std::string& dotted) {
  const Descriptor* message = v1::Scene::descriptor();
  std::string rest = dotted;
  while (true) {
    const auto dot = rest.find('.');
    const FieldDescriptor* field = message->FindFieldByName(rest.substr(0, dot));
    if (!field || dot == std::string::npos) return field;
    if (field->type() != FieldDescriptor::TYPE_MESSAGE) return nullptr;
    message = field->message_type();
    rest = rest.substr(dot + 1);
  }
}

void CollectLeaves(const Descriptor* message, const std::string& prefix,
                   std::vector<std::string>& out) {
  for (int i = 0; i < message->field_count(); ++i) {
    const FieldDescriptor* f = message->field(i);
    const std::string name = prefix.empty() ? f->name() : prefix + "." + f->name();
    if (f->type() == FieldDescriptor::TYPE_MESSAGE)
      CollectLeaves(f->message_type(), name, out);
    else
      out.push_back(name);
  }
}

TEST(SceneRequest, EverySceneFieldIsInTheApiAndBack) {
  for (const SceneField& f : SceneFields())
    EXPECT_NE(ProtoField(std::string(f.name)), nullptr) << f.name << " missing from dembuf.proto";
  std::vector<std::string> leaves;
  CollectLeaves(v1::Scene::descriptor(), "", leaves);
  for (const std::string& leaf : leaves)
    EXPECT_NE(FindSceneField(leaf), nullptr) << leaf << " in dembuf.proto is no scene field";
}

TEST(SceneRequest, ValuesArriveExactlyAndInOrder) {
  v1::SceneSpec spec;
  spec.set_preset("e2");
  spec.set_scene_toml("[bed]\nthickness_m = 0.02\n");
  spec.mutable_scene()->mutable_bed()->set_thickness_m(0.1 / 3.0);  // overrides the text
  spec.mutable_scene()->mutable_projectile()->set_mass_kg(0.123456789012345678);
  spec.mutable_scene()->mutable_output()->add_snapshot_times_s(1.0 / 7.0);
  spec.add_set("projectile.speed_m_s=4.5");  // overrides the preset's 5
  const Scene scene = ResolveSceneSpec(spec);
  EXPECT_EQ(scene.bed.thickness_m, 0.1 / 3.0);
  EXPECT_EQ(scene.projectile.mass_kg, 0.123456789012345678);
  ASSERT_EQ(scene.output.snapshot_times_s.size(), 1u);
  EXPECT_EQ(scene.output.snapshot_times_s[0], 1.0 / 7.0);
  EXPECT_EQ(scene.projectile.speed_m_s, 4.5);
  EXPECT_EQ(scene.projectile.height_m, PresetScene("e2").projectile.height_m);
}

TEST(SceneRequest, BadValuesNameTheirField) {
  auto message = [](const v1::SceneSpec& spec) {
    try {
      AdmitJob(spec, std::nullopt, ResourceLimits{});
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  v1::SceneSpec nan;
  nan.mutable_scene()->mutable_material()->set_restitution(std::nan(""));
  EXPECT_NE(message(nan).find("material.restitution"), std::string::npos) << message(nan);
  v1::SceneSpec huge;
  huge.mutable_scene()->mutable_bed()->set_seed(INT64_MAX);
  EXPECT_NE(message(huge).find("bed.seed"), std::string::npos) << message(huge);
  v1::SceneSpec import;
  import.mutable_scene()->mutable_bed()->set_import("/etc/passwd");
  EXPECT_NE(message(import).find("bed.import"), std::string::npos) << message(import);
  // What a job costs (its samples among it) is checked against the server's limits, from
  // its resource estimate (ResourceEstimate.*, tests/robustness/costs_test.sh).
}

TEST(SceneRequest, AFieldTheApiDoesNotHaveIsRefusedNotDropped) {
  // A client of another version: field 18 of Bed was bed.quench_cut_column, withdrawn. Its
  // bytes arrive as an unknown field; the job would run without what was asked.
  v1::SceneSpec spec;
  spec.set_preset("e2");
  v1::Bed old_bed;
  old_bed.set_thickness_m(0.02);
  std::string bytes = old_bed.SerializeAsString();
  bytes += std::string("\x90\x01\x01", 3);  // field 18, varint: true
  ASSERT_TRUE(spec.mutable_scene()->mutable_bed()->ParseFromString(bytes));
  try {
    ResolveSceneSpec(spec);
    FAIL() << "an unknown field was dropped";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), "bed");
    EXPECT_NE(std::string(e.what()).find("field number 18"), std::string::npos) << e.what();
  }
}

TEST(SceneRequest, RepeatedFieldsAreBounded) {
  v1::SceneSpec spec;
  for (int k = 0; k <= kMaxAssignments; ++k) spec.add_set("projectile.speed_m_s=1");
  try {
    ResolveSceneSpec(spec);
    FAIL() << "1001 assignments accepted";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), "set");
    EXPECT_NE(std::string(e.what()).find("1001 assignments; at most 1000"), std::string::npos);
  }
  v1::SubmitSweepRequest sweep;
  for (int k = 0; k <= kMaxAxes; ++k) sweep.add_axes()->set_field("projectile.speed_m_s");
  EXPECT_THROW(CheckSweepAxes(sweep), SceneError);
  sweep.clear_axes();
  auto* axis = sweep.add_axes();
  axis->set_field("projectile.speed_m_s");
  for (int k = 0; k <= kMaxAxisValues; ++k) axis->add_values("1");
  try {
    CheckSweepAxes(sweep);
    FAIL() << "10001 values accepted";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), "projectile.speed_m_s");
  }
}

class StoreTest : public testing::Test {
 protected:
  fs::path path = fs::path(testing::TempDir()) /
                  ("store-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
                   testing::UnitTest::GetInstance()->current_test_info()->name() + ".db");
  void SetUp() override {
    fs::remove(path);
    fs::remove(path.string() + "-wal");
    fs::remove(path.string() + "-shm");
  }
};

TEST_F(StoreTest, ResultsSurviveReopeningExactly) {
  std::int64_t id = 0;
  const std::vector<ImpactSample> samples = {{0.0, 1.0 / 3.0, -2.5, 0.1, -5.0, 7.0},
                                             {1e-5, 13456.789, 0.0, std::nan(""), 0.0, 0.0}};
  {
    Store store(path.string());
    JobRecord job;
    job.owner = "ada";
    job.name = "one";
    job.scene_toml = "gravity_m_s2 = 9.81\n";
    store.AddJob(job);
    id = job.id;
    store.MarkStarted(id, JobState::kRunning, "host", "0.1.0");
    store.FinishJob(id, JobState::kDone, "", {"{\"P_N\": 1}\n", samples, 0, {}});
  }
  Store store(path.string());
  const auto job = store.GetJob(id);
  ASSERT_TRUE(job);
  EXPECT_EQ(job->state, JobState::kDone);
  EXPECT_EQ(job->attempts, 1);
  const auto results = store.GetResults(id);
  ASSERT_TRUE(results);
  EXPECT_EQ(results->summary_json, "{\"P_N\": 1}\n");
  ASSERT_EQ(results->samples.size(), 2u);
  EXPECT_EQ(results->samples[0].plate_force_N, 1.0 / 3.0);
  EXPECT_EQ(results->samples[1].plate_force_N, 13456.789);
  EXPECT_TRUE(std::isnan(results->samples[1].projectile_z_m));
}

TEST_F(StoreTest, InterruptedJobsGoBackToTheQueue) {
  Store store(path.string());
  JobRecord a, b;
  a.scene_toml = b.scene_toml = "x";
  store.AddJob(a);
  store.AddJob(b);
  store.MarkStarted(a.id, JobState::kRunning, "h", "v");
  const auto requeued = store.RequeueInterrupted("interrupted").requeued;
  ASSERT_EQ(requeued.size(), 1u);
  EXPECT_EQ(requeued[0].id, a.id);
  EXPECT_EQ(store.GetJob(a.id)->state, JobState::kQueued);
  EXPECT_EQ(store.GetJob(a.id)->error, "interrupted");
  EXPECT_EQ(store.QueuedJobs().size(), 2u);
}

// A sweep whose jobs are deleted one by one goes with its last job (it stayed in the
// listings, counting nothing); a sweep asked for by its id goes even without jobs.
TEST_F(StoreTest, ASweepLeftWithoutJobsIsDeletedWithTheLast) {
  Store store(path.string());
  SweepRecord sweep;
  sweep.owner = "ada";
  std::vector<JobRecord> jobs(2);
  for (JobRecord& job : jobs) {
    job.owner = "ada";
    job.scene_toml = "x";
  }
  store.AddSweep(sweep, jobs, "request-1");
  for (const JobRecord& job : jobs)
    store.FinishJob(job.id, JobState::kDone, "", {"{}\n", {}, 0, {}});
  store.DeleteJobs({jobs[0].id}, 0);
  ASSERT_TRUE(store.GetSweep(sweep.id));
  store.DeleteJobs({jobs[1].id}, 0);
  EXPECT_FALSE(store.GetSweep(sweep.id));
  EXPECT_FALSE(store.FindSubmission("ada", "request-1"));
  SweepRecord empty;
  empty.owner = "ada";
  std::vector<JobRecord> none;
  store.AddSweep(empty, none);
  store.DeleteJobs({}, empty.id);
  EXPECT_FALSE(store.GetSweep(empty.id));
}

// A deleted job's id is not given to the next job (SQLite gives the largest id again): the
// Slurm executor's folder of the deleted job would be taken for the new one's, and failed it.
TEST_F(StoreTest, ADeletedJobsIdIsNeverGivenAgain) {
  std::int64_t newest = 0;
  {
    Store store(path.string());
    JobRecord first, second;
    first.owner = second.owner = "ada";
    store.AddJob(first);
    store.AddJob(second);
    store.FinishJob(second.id, JobState::kDone, "", {"{}\n", {}, 0, {}});
    newest = second.id;
    store.DeleteJobs({newest}, 0);
  }
  Store store(path.string());
  JobRecord next;
  next.owner = "ada";
  store.AddJob(next);
  EXPECT_EQ(next.id, newest + 1);
}

// A done job of scene "s" owned by `owner` (a copy of `from`'s result when given).
JobRecord DoneOfScene(Store& store, const std::string& owner, std::int64_t from = 0,
                      const std::string& scene_toml = "[scene]\n") {
  JobRecord job;
  job.owner = owner;
  job.scene_hash = "s";
  job.scene_toml = scene_toml;
  job.reused_from = from;
  store.AddJob(job);
  if (from == 0) store.FinishJob(job.id, JobState::kDone, "", {"{}\n", {}, 0, {}});
  return job;
}

// Results deleted between their lookup and the filing of the jobs that were to reuse them:
// the filing is undone whole (it used to file the jobs queued, past the quota of queued jobs,
// which counted them as done), and every gone result is named at once, so that the filing is
// tried once more, not once per result.
TEST_F(StoreTest, AFilingThatWouldReuseDeletedResultsIsUndoneWhole) {
  Store store(path.string());
  const JobRecord kept = DoneOfScene(store, "ada");
  std::vector<std::int64_t> deleted;
  for (int k = 0; k < 3; ++k) deleted.push_back(DoneOfScene(store, "ada").id);
  store.DeleteJobs(deleted, 0);
  SweepRecord sweep;
  sweep.owner = "bob";
  std::vector<JobRecord> jobs(5);
  for (JobRecord& job : jobs) job.owner = "bob";
  jobs[0].reused_from = kept.id;
  for (int k = 0; k < 3; ++k) jobs[k + 1].reused_from = deleted[k];
  try {
    store.AddSweep(sweep, jobs, "request-1");
    FAIL() << "filed, though the results to reuse had gone";
  } catch (const ReusedResultGone& e) {
    EXPECT_EQ(e.gone, deleted);
  }
  EXPECT_TRUE(store.QueuedJobs().empty());
  EXPECT_FALSE(store.FindSubmission("bob", "request-1"));
  JobRecord alone;
  alone.owner = "bob";
  alone.reused_from = deleted[0];
  EXPECT_THROW(store.AddJob(alone), ReusedResultGone);
  EXPECT_TRUE(store.QueuedJobs().empty());
}

// The owner is filtered before the bound, and originals come first: ten copies of ada's
// result owned by others cannot hide bob's own.
TEST_F(StoreTest, DoneJobsOfASceneAreThoseOfTheOwnerOriginalsFirst) {
  Store store(path.string());
  const JobRecord bobs = DoneOfScene(store, "bob");
  const JobRecord adas = DoneOfScene(store, "ada");
  for (int k = 0; k < 10; ++k) DoneOfScene(store, "eve", adas.id);
  const std::vector<JobRecord> of_bob = store.DoneJobsOfScene("s", "[scene]\n", "", "bob");
  ASSERT_EQ(of_bob.size(), 1u);
  EXPECT_EQ(of_bob[0].id, bobs.id);
  const std::vector<JobRecord> any = store.DoneJobsOfScene("s", "[scene]\n", "", std::nullopt, 2);
  ASSERT_EQ(any.size(), 2u);
  EXPECT_EQ(any[0].id, adas.id);
  EXPECT_EQ(any[1].id, bobs.id);
}

// The scene hash is 64 bits of FNV-1a, which a search of about 2^32 scenes collides on purpose:
// a done job of another scene text under the same hash is not one to reuse.
TEST_F(StoreTest, DoneJobsOfASceneHaveItsTextNotOnlyItsHash) {
  Store store(path.string());
  const JobRecord slow = DoneOfScene(store, "bob", 0, "[projectile]\nspeed_m_s = 3.0\n");
  const JobRecord fast = DoneOfScene(store, "bob", 0, "[projectile]\nspeed_m_s = 5.0\n");
  const std::vector<JobRecord> found =
      store.DoneJobsOfScene("s", "[projectile]\nspeed_m_s = 5.0\n", "", "bob");
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].id, fast.id);
  EXPECT_TRUE(
      store.DoneJobsOfScene("s", "[projectile]\nspeed_m_s = 4.0\n", "", std::nullopt).empty());
  (void)slow;
}

// A job's record counts in its owner's stored bytes whatever its state (cancelled sweeps of
// long command lines grew the database by 477 MB, counted nowhere), as JobRowBytes says
// before it is filed; the SQL and the function agree byte for byte.
TEST_F(StoreTest, AJobsRecordCountsInItsOwnersStoredBytes) {
  Store store(path.string());
  JobRecord job;
  job.owner = "ada";
  job.name = "r\u00e9sum\u00e9";  // bytes, not characters
  job.scene_toml = "x = 1\n";
  job.command_line = std::string(4000, 'c');
  job.sweep_values = {"0.01", "2"};
  const std::int64_t row = JobRowBytes(job);
  EXPECT_GT(row, 4000 + kJobRowOverheadBytes);
  store.AddJob(job);
  EXPECT_EQ(store.StoredBytesOf("ada"), row);
  EXPECT_EQ(store.StoredBytesOf("bob"), 0);
  store.FinishJob(job.id, JobState::kCancelled, "cancelled while queued", {"", {}, 0, {}});
  const std::int64_t with_error = store.StoredBytesOf("ada");
  EXPECT_EQ(with_error,
            row + static_cast<std::int64_t>(std::string("cancelled while queued").size()));
  EXPECT_EQ(store.DeleteJobs({job.id}, 0), with_error);
  EXPECT_EQ(store.StoredBytesOf("ada"), 0);
}

// A finished job's peak plate force and P are kept in its record as it ends, so that every
// listing shows them without reading summaries (/api/jobs showed the peak 0.0 of a job whose
// summary said 3559 N, `list --json` none); jobs that ended before get them at the upgrade.
TEST_F(StoreTest, AFinishedJobsPeakAndPAreInItsRecord) {
  std::vector<std::int64_t> ids;
  {
    Store store(path.string());
    for (int k = 0; k < 3; ++k) {
      JobRecord job;
      job.scene_toml = "x";
      store.AddJob(job);
      ids.push_back(job.id);
    }
    store.FinishJob(ids[0], JobState::kDone, "",
                    {"{\"P_N\": 2500.5, \"peak_plate_force_N\": 3559.3}\n", {}, 0, {}});
    store.FinishJob(ids[1], JobState::kFailed, "unstable", {"", {}, 0, {}});
    store.FinishJob(ids[2], JobState::kDone, "", {"{\"P_N\": \"many\"}\n", {}, 0, {}});
    auto listed = [&](std::int64_t id) {
      JobFilter filter;
      for (const JobRecord& job : store.ListJobs(filter))
        if (job.id == id) return job;
      return JobRecord();
    };
    EXPECT_EQ(listed(ids[0]).peak_plate_force_N, 3559.3);
    EXPECT_EQ(listed(ids[0]).P_N, 2500.5);
    EXPECT_EQ(store.GetJob(ids[0])->P_N, 2500.5);
    EXPECT_FALSE(listed(ids[1]).peak_plate_force_N.has_value());
    EXPECT_FALSE(listed(ids[2]).P_N.has_value());  // not a number: not known
  }
  {
    // The database as the version before kept them left it.
    Database db(path.string());
    db.Execute(
        "DROP INDEX jobs_done_by_scene; "
        "ALTER TABLE jobs DROP COLUMN peak_plate_force_N; ALTER TABLE jobs DROP COLUMN P_N; "
        "ALTER TABLE jobs DROP COLUMN slurm_task; DROP TABLE notifications; "
        "ALTER TABLE jobs DROP COLUMN reused_from; DROP INDEX jobs_by_scene; "
        "PRAGMA user_version = 10");
    // A summary changed since it was stored (valid JSON, another P): its checksum fails.
    db.Execute("UPDATE results SET summary_json = '{\"P_N\": 9999}' WHERE job_id = " +
               std::to_string(ids[2]));
  }
  Store store(path.string());
  EXPECT_EQ(store.GetJob(ids[0])->peak_plate_force_N, 3559.3);
  EXPECT_EQ(store.GetJob(ids[0])->P_N, 2500.5);
  EXPECT_FALSE(store.GetJob(ids[1])->P_N.has_value());
  EXPECT_FALSE(store.GetJob(ids[2])->P_N.has_value());  // not taken from a damaged summary
}

// A listing reads no scenes and stops at its byte bound (100,000 jobs of long command lines
// made answers of 219 MB, and the daemon 1.75 GB).
TEST_F(StoreTest, AListingIsBoundedInBytesAndReadsNoScenes) {
  Store store(path.string());
  for (int k = 0; k < 10; ++k) {
    JobRecord job;
    job.owner = "ada";
    job.scene_toml = std::string(1000, 's');
    job.command_line = std::string(1000, 'c');
    store.AddJob(job);
  }
  JobFilter filter;
  filter.with_scene = false;
  bool over = true;
  const std::vector<JobRecord> all = store.ListJobs(filter, &over);
  ASSERT_EQ(all.size(), 10u);
  EXPECT_FALSE(over);
  EXPECT_EQ(all[0].scene_toml, "");
  EXPECT_EQ(all[0].command_line.size(), 1000u);
  filter.max_bytes = 3 * JobRowBytes(all[0]) + 1;
  const std::vector<JobRecord> some = store.ListJobs(filter, &over);
  EXPECT_TRUE(over);
  EXPECT_EQ(some.size(), 4u);  // the one that passed the bound tells it was passed
  filter.with_scene = true;
  EXPECT_EQ(store.ListJobs(filter)[0].scene_toml.size(), 1000u);
}

// n samples whose values say their index.
std::vector<ImpactSample> Samples(std::int64_t first, std::int64_t n) {
  std::vector<ImpactSample> samples;
  for (std::int64_t k = first; k < first + n; ++k)
    samples.push_back({k * 1e-6, k / 3.0, -k / 7.0, 0.1, -5.0, static_cast<double>(k)});
  return samples;
}

void ExpectSamples(const std::vector<ImpactSample>& got, std::int64_t first, std::int64_t n) {
  ASSERT_EQ(got.size(), static_cast<std::size_t>(n));
  const auto want = Samples(first, n);
  for (std::int64_t k = 0; k < n; ++k) {
    ASSERT_EQ(got[k].t_s, want[k].t_s) << k;
    ASSERT_EQ(got[k].plate_force_N, want[k].plate_force_N) << k;
    ASSERT_EQ(got[k].wall_force_z_N, want[k].wall_force_z_N) << k;
    ASSERT_EQ(got[k].projectile_force_z_N, want[k].projectile_force_z_N) << k;
  }
}

TEST_F(StoreTest, ASeriesLongerThanABlobMayBeIsStoredInChunks) {
  // SQLite refuses a blob longer than its length limit ("string or blob too big"), which once
  // threw in the worker and killed the daemon, again at every restart. Here the limit is
  // lowered to 10,000 bytes, and a series of 52,800 bytes is stored in chunks of 100 samples
  // while the job runs, then the rest with the result.
  std::int64_t id = 0;
  StoreOptions small;
  small.chunk_samples = 100;
  small.max_blob_bytes = 10000;
  {
    Store store(path.string(), small);
    JobRecord job;
    job.scene_toml = "x";
    store.AddJob(job);
    id = job.id;
    store.MarkStarted(id, JobState::kRunning, "h", "v");
    store.AppendSeries(id, 0, Samples(0, 640));
    store.AppendSeries(id, 640, Samples(640, 360));
    ExpectSamples(store.ReadSeries(id, 150, 100), 150, 100);  // across two chunks
    store.FinishJob(id, JobState::kDone, "", {"{}\n", Samples(1000, 100), 1000, {}});
  }
  Store store(path.string(), small);
  const auto results = store.GetResults(id);
  ASSERT_TRUE(results);
  ExpectSamples(results->samples, 0, 1100);
  ExpectSamples(store.ReadSeries(id, 1050, 1000), 1050, 50);
}

TEST_F(StoreTest, ADamagedChunkIsReportedNotServed) {
  std::int64_t id = 0;
  {
    Store store(path.string());
    JobRecord job;
    job.scene_toml = "x";
    store.AddJob(job);
    id = job.id;
    store.FinishJob(id, JobState::kDone, "", {"{}\n", Samples(0, 10), 0, {}});
  }
  {
    Database db(path.string());
    db.Execute("UPDATE series_chunks SET data = zeroblob(length(data))");
  }
  Store store(path.string());
  try {
    store.GetResults(id);
    FAIL() << "served a damaged series";
  } catch (const StoreError& e) {
    EXPECT_NE(std::string(e.what()).find("damaged"), std::string::npos) << e.what();
  }
}

TEST_F(StoreTest, AFlippedByteInASummaryOrAResultFileIsReportedNotServed) {
  // One flipped byte in a stored summary was served as the result (P = 9625 N beside
  // Pa = 4625 N): summaries and result files had no checksums.
  std::int64_t id = 0;
  const std::string summary = "{\"P_N\": 4625, \"Pa_N\": 4625}\n";
  const std::string big(3 << 20, 'v');  // hashed in pieces of 1 MiB
  {
    Store store(path.string());
    JobRecord job;
    job.scene_toml = "x";
    store.AddJob(job);
    id = job.id;
    store.FinishJob(id, JobState::kDone, "",
                    {summary, Samples(0, 10), 0, {{"snapshots/peak/beads.vtp", big}}});
    EXPECT_EQ(store.Summary(id), summary);
    EXPECT_EQ(store.ReadJobFile(id, "snapshots/peak/beads.vtp", 0, 10), "vvvvvvvvvv");
    EXPECT_TRUE(store.Check().problems.empty());
  }
  {
    Database db(path.string());
    db.Execute("UPDATE results SET summary_json = '{\"P_N\": 9625, \"Pa_N\": 4625}' || char(10)");
    db.Execute(
        "UPDATE job_files SET data = CAST(substr(data, 1, 2097152) || 'w' || "
        "substr(data, 2097154) AS BLOB)");
  }
  Store store(path.string());
  EXPECT_THROW(store.Summary(id), DamagedData);
  EXPECT_THROW(store.GetResults(id), DamagedData);
  EXPECT_THROW(store.ReadJobFile(id, "snapshots/peak/beads.vtp", 0, 10), DamagedData);
  const CheckReport report = store.Check();
  ASSERT_EQ(report.problems.size(), 2u);
  EXPECT_EQ(report.problems[0], "the summary of job " + std::to_string(id) +
                                    " is damaged: it does not match its checksum");
  EXPECT_EQ(report.problems[1], "the result file snapshots/peak/beads.vtp of job " +
                                    std::to_string(id) +
                                    " is damaged: it does not match its checksum");
  EXPECT_EQ(report.files, 1);
  // A cleared checksum is no checksum: not taken on trust.
  {
    Database db(path.string());
    db.Execute("UPDATE results SET summary_json = '" + summary.substr(0, summary.size() - 1) +
               "' || char(10), summary_sha256 = ''");
  }
  EXPECT_THROW(Store(path.string()).Summary(id), DamagedData);
}

TEST_F(StoreTest, ResultsStoredBeforeChecksumsGetThemAndLoseTheirTokensAtTheUpgrade) {
  std::int64_t id = 0;
  {
    Store store(path.string());
    JobRecord job;
    job.scene_toml = "x";
    store.AddJob(job);
    id = job.id;
    store.FinishJob(id, JobState::kDone, "", {"{}\n", Samples(0, 10), 0, {{"frames.pvd", "p"}}});
  }
  {
    // The database as the version before checksums left it, with a token in a command line
    // (a client before this version kept it).
    Database db(path.string());
    db.Execute(
        "DROP INDEX jobs_done_by_scene; "
        "ALTER TABLE results DROP COLUMN summary_sha256; ALTER TABLE results DROP COLUMN "
        "series_sha256; ALTER TABLE job_files DROP COLUMN sha256; DROP TABLE bed_files; "
        "ALTER TABLE jobs DROP COLUMN bed_file; ALTER TABLE jobs DROP COLUMN result_nonce; "
        "ALTER TABLE jobs DROP COLUMN peak_plate_force_N; ALTER TABLE jobs DROP COLUMN P_N; "
        "ALTER TABLE jobs DROP COLUMN slurm_task; DROP TABLE notifications; "
        "ALTER TABLE jobs DROP COLUMN reused_from; DROP INDEX jobs_by_scene; "
        "PRAGMA user_version = 7");
    db.Execute("UPDATE jobs SET command_line = 'dembuf --token 0123abcd submit'");
    db.Execute(
        "UPDATE results SET summary_json = "
        "'{\"provenance\": {\"command_line\": \"dembuf --token 0123abcd submit\"}}'");
  }
  Store store(path.string());
  EXPECT_EQ(store.GetJob(id)->command_line, "dembuf --token <hidden> submit");
  EXPECT_EQ(store.Summary(id),
            "{\"provenance\": {\"command_line\": \"dembuf --token <hidden> submit\"}}");
  EXPECT_EQ(store.ReadJobFile(id, "frames.pvd", 0, 10), "p");
  EXPECT_TRUE(store.Check().problems.empty());
}

TEST_F(StoreTest, AJobInterruptedTwiceIsFailedNotRunForEver) {
  // A job that crashes the daemon would crash it again at every restart: the second time it
  // is found interrupted, it fails ("poison job") and the daemon goes on with the others.
  Store store(path.string());
  JobRecord job;
  job.scene_toml = "x";
  store.AddJob(job);
  store.MarkStarted(job.id, JobState::kRunning, "h", "v");
  store.AppendSeries(job.id, 0, Samples(0, 10));
  auto first = store.RequeueInterrupted("interrupted");
  ASSERT_EQ(first.requeued.size(), 1u);
  EXPECT_TRUE(first.poisoned.empty());
  EXPECT_EQ(store.GetJob(job.id)->state, JobState::kQueued);
  // The next attempt starts with no samples of the one before.
  store.MarkStarted(job.id, JobState::kRunning, "h", "v");
  EXPECT_TRUE(store.ReadSeries(job.id, 0, 100).empty());
  store.AppendSeries(job.id, 0, Samples(0, 10));
  auto second = store.RequeueInterrupted("interrupted");
  EXPECT_TRUE(second.requeued.empty());
  ASSERT_EQ(second.poisoned.size(), 1u);
  const auto failed = store.GetJob(job.id);
  EXPECT_EQ(failed->state, JobState::kFailed);
  EXPECT_NE(failed->error.find("poison job"), std::string::npos) << failed->error;
  EXPECT_TRUE(store.QueuedJobs().empty());
  // A clean shutdown's requeue is no crash: a job requeued that way is not counted.
  JobRecord other;
  other.scene_toml = "y";
  store.AddJob(other);
  for (int k = 0; k < 3; ++k) {
    store.MarkStarted(other.id, JobState::kRunning, "h", "v");
    store.SetState(other.id, JobState::kQueued, "interrupted by a daemon shutdown");
  }
  store.MarkStarted(other.id, JobState::kRunning, "h", "v");
  EXPECT_EQ(store.RequeueInterrupted("interrupted").requeued.size(), 1u);
}

std::string ReadAll(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST_F(StoreTest, RefusesAForeignFileAndLeavesItAlone) {
  { std::ofstream(path, std::ios::binary) << std::string(8192, '\x5a'); }
  const std::string before = ReadAll(path);
  try {
    Store store(path.string());
    FAIL() << "opened a file that is not a database";
  } catch (const StoreError& e) {
    EXPECT_NE(std::string(e.what()).find("leaves it untouched"), std::string::npos) << e.what();
  }
  EXPECT_EQ(ReadAll(path), before);
}

TEST_F(StoreTest, RefusesADatabaseOfAnotherApplication) {
  {
    Database db(path.string());
    db.Execute("CREATE TABLE accounts (id INTEGER)");
  }
  EXPECT_THROW(Store store(path.string()), StoreError);
}

TEST_F(StoreTest, RefusesANewerSchema) {
  { Store store(path.string()); }
  {
    Database db(path.string());
    db.Execute("PRAGMA user_version = 99");
  }
  try {
    Store store(path.string());
    FAIL() << "opened a newer schema";
  } catch (const StoreError& e) {
    EXPECT_NE(std::string(e.what()).find("newer"), std::string::npos) << e.what();
  }
}

// A user's bed files have a room: the oldest whose jobs have ended make way; those a queued
// job imports do not, and a file that still does not fit is refused.
TEST_F(StoreTest, BedFilesMakeRoomButKeepThoseAQueuedJobImports) {
  Store store(path.string());
  // A kilobyte named by its SHA-256, as the daemon keeps it.
  std::map<std::string, std::string> sha;
  auto file = [&](const std::string& name) {
    const std::string data = std::string(999, 'x') + name;
    sha[name] = Sha256Hex(data);
    return BedFile{"alice", sha[name], "bed.txt", std::make_shared<const std::string>(data)};
  };
  EXPECT_TRUE(store.PutBedFile(file("a"), 2500));
  EXPECT_TRUE(store.PutBedFile(file("b"), 2500));
  EXPECT_FALSE(store.PutBedFile(file("b"), 2500));  // the same bytes again: kept as they were
  JobRecord waiting;
  waiting.owner = "alice";
  waiting.scene_toml = "x";
  waiting.bed_file = sha["b"];
  store.AddJob(waiting);
  EXPECT_TRUE(store.PutBedFile(file("c"), 2500));  // "a" made way, "b" is waited for
  EXPECT_FALSE(store.GetBedFile("alice", sha["a"]));
  EXPECT_TRUE(store.GetBedFile("alice", sha["b"]));
  store.SetState(waiting.id, JobState::kRunning);
  EXPECT_THROW(store.PutBedFile(file("d"), 1500), BedFilesFull);  // "b" still waited for
  EXPECT_TRUE(store.GetBedFile("alice", sha["c"]));  // (and nothing removed for nothing)
  store.SetState(waiting.id, JobState::kDone);
  EXPECT_TRUE(store.PutBedFile(file("d"), 2500));  // "b", the oldest, made way
  EXPECT_FALSE(store.GetBedFile("alice", sha["b"]));
  EXPECT_TRUE(store.GetBedFile("alice", sha["c"]));
  EXPECT_TRUE(store.GetBedFile("bob", sha["d"]) == std::nullopt);  // by owner
}

// The connection's one way to change the database: a Write not committed leaves nothing.
TEST_F(StoreTest, AWriteNotCommittedIsRolledBack) {
  Connection connection(path.string(), {});
  {
    Connection::Writing db = connection.Write();
    db->Execute("CREATE TABLE t (x INTEGER)");
    db.Commit();
  }
  {
    Connection::Writing db = connection.Write();
    db->Execute("INSERT INTO t VALUES (1)");
  }  // (an exception would leave it so)
  {
    Connection::Writing db = connection.Write();
    db->Execute("INSERT INTO t VALUES (2)");
    db.Commit();
  }
  Connection::Reading db = connection.Read();
  Statement& rows = db->Prepare("SELECT group_concat(x) FROM t");
  rows.Bind();
  ASSERT_TRUE(rows.Step());
  EXPECT_EQ(rows.Text(0), "2");
  rows.Run();
}

// Making room and keeping the new file are one change: a file the database refuses (here a
// blob past its length limit) leaves the older files that would have made way for it.
TEST_F(StoreTest, ABedFileThatCannotBeKeptRemovesNoOther) {
  StoreOptions small;
  small.max_blob_bytes = 1500;
  Store store(path.string(), small);
  auto file = [](std::size_t bytes, char fill) {
    const std::string data(bytes, fill);
    return BedFile{"alice", Sha256Hex(data), "bed.txt", std::make_shared<const std::string>(data)};
  };
  const BedFile kept = file(1000, 'a');
  ASSERT_TRUE(store.PutBedFile(kept, 2000));
  EXPECT_ANY_THROW(store.PutBedFile(file(1600, 'b'), 2000));  // "kept" would make way
  EXPECT_TRUE(store.GetBedFile("alice", kept.sha256));
}

TEST_F(StoreTest, BedsRoundTripExactly) {
  Store store(path.string());
  PreparedBed bed;
  bed.hash = "0123456789abcdef";
  bed.stage = "cut";
  bed.surface_m = 0.1 / 3.0;
  bed.beads.position.push_back(dem::Vec3(1.0 / 3.0, 2.0 / 7.0, 0.01));
  bed.beads.velocity.push_back(dem::Vec3::Zero());
  bed.beads.angular_velocity.push_back(dem::Vec3::Zero());
  bed.beads.force.push_back(dem::Vec3::Zero());
  bed.beads.torque.push_back(dem::Vec3::Zero());
  bed.beads.radius.push_back(0.0021);
  bed.beads.mass.push_back(1e-4);
  bed.beads.inv_mass.push_back(1e4);
  EXPECT_FALSE(store.beds().Contains(bed.hash));
  store.beds().Save(bed);
  EXPECT_TRUE(store.beds().Contains(bed.hash));
  const auto back = store.beds().Load(bed.hash);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->surface_m, bed.surface_m);
  EXPECT_EQ(back->beads.position[0], bed.beads.position[0]);
  EXPECT_EQ(back->beads.radius[0], bed.beads.radius[0]);
}

TEST_F(StoreTest, ResultFilesAreStoredWithTheJobAndReadInPieces) {
  std::int64_t id = 0;
  const std::string big(3000, 'x');
  {
    Store store(path.string());
    JobRecord job;
    job.scene_toml = "x";
    store.AddJob(job);
    id = job.id;
    store.MarkStarted(id, JobState::kRunning, "h", "v");
    store.PutJobFiles(id, {{"snapshots/t_1ms/a.csv", "a,b\n"}});
    store.FinishJob(id, JobState::kDone, "", {"{}\n", {}, 0, {{"snapshots/peak/big.vtk", big}}});
  }
  Store store(path.string());
  const std::vector<JobFileInfo> files = store.JobFiles(id);
  ASSERT_EQ(files.size(), 2u);
  EXPECT_EQ(files[0].path, "snapshots/peak/big.vtk");  // in path order
  EXPECT_EQ(files[0].size, 3000);
  EXPECT_EQ(files[1].path, "snapshots/t_1ms/a.csv");
  std::string pieces;
  for (std::int64_t offset = 0; offset < 3000; offset += 1024)
    pieces += store.ReadJobFile(id, "snapshots/peak/big.vtk", offset, 1024);
  EXPECT_EQ(pieces, big);
  EXPECT_EQ(store.ReadJobFile(id, "snapshots/peak/big.vtk", 3000, 1024), "");
  EXPECT_EQ(store.ReadJobFile(id, "no/such/file", 0, 1024), "");
  // A job that starts again (after a crash) starts without the files of its first try.
  store.MarkStarted(id, JobState::kRunning, "h", "v");
  EXPECT_TRUE(store.JobFiles(id).empty());
}

// The daemon closes its store as it stops, while its access policy still stands: the policy's
// reader of the users read the closed store (dembufd died of SIGSEGV one stop in fifty).
TEST_F(StoreTest, TheAccessPolicyStopsReadingTheUsersBeforeTheStoreGoes) {
  auto store = std::make_unique<Store>(path.string());
  AccessPolicy policy(*store, AccessMode::kTokens);
  policy.Stop();
  store.reset();
  // A reader still running reads the freed store within kUsersRefresh (AddressSanitizer
  // reports it at once; here it crashes now and then).
  std::this_thread::sleep_for(3 * kUsersRefresh);
  EXPECT_EQ(policy.mode(), AccessMode::kTokens);
}

}  // namespace
}  // namespace dembuf::server
