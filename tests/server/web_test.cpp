// The web side's pieces without the network: the job feed that both the gRPC watch and the
// pages' event streams read (stored, live and queued jobs), the JSON of jobs and sweeps (a
// sweep's points so far, from its jobs' summaries), login sessions, stream caps, and the
// --http address.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <thread>

#include "dembuf/study/files/run_output.h"
#include "doors/api_messages.h"
#include "doors/stream_limits.h"
#include "doors/web/sessions.h"
#include "doors/web/web_views.h"
#include "jobs/job_feed.h"
#include "process/config.h"
#include "store/store.h"

namespace dembuf::server {
namespace {

namespace fs = std::filesystem;

/// An executor that runs nothing: the tests set which jobs are live.
class FakeExecutor final : public Executor {
 public:
  void Start() override {}
  void Admit(std::size_t, const std::function<std::vector<JobRecord>()>& add) override { add(); }
  bool Cancel(std::int64_t) override { return false; }
  std::shared_ptr<LiveJob> Live(std::int64_t id) override {
    const auto found = live.find(id);
    return found == live.end() ? nullptr : found->second;
  }
  int queued() const override { return 0; }
  int running() const override { return static_cast<int>(live.size()); }
  ExecutorInfo info() const override { return {"fake", 1, 1, 10}; }
  void Shutdown(std::chrono::seconds) override {}

  std::map<std::int64_t, std::shared_ptr<LiveJob>> live;
};

ImpactSample Sample(int k) {
  const double t = 1e-5 * k;
  return {t, 1000.0 * std::sin(0.01 * k) + k * 1e-3, -0.5 * k, 0.1 - t, -2.0, 3.0};
}

class JobFeedTest : public testing::Test {
 protected:
  fs::path path =
      fs::path(testing::TempDir()) /
      ("feed-" + std::string(testing::UnitTest::GetInstance()->current_test_info()->name()) +
       ".db");
  void SetUp() override {
    for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(path.string() + suffix);
    store = std::make_unique<Store>(path.string(), StoreOptions{1000, 0});
  }
  /// A job that runs, its live part known to the executor.
  std::pair<std::int64_t, std::shared_ptr<LiveJob>> AddRunningJob() {
    const std::int64_t id = AddJob();
    store->MarkStarted(id, JobState::kRunning, "host", "0.1.0");
    auto live = std::make_shared<LiveJob>(id);
    live->SetState(JobState::kRunning);
    executor.live[id] = live;
    return {id, live};
  }
  std::int64_t AddJob() {
    JobRecord job;
    job.owner = "ada";
    job.name = "feed";
    job.scene_toml = "gravity_m_s2 = 9.81\n";
    store->AddJob(job);
    return job.id;
  }
  std::unique_ptr<Store> store;
  FakeExecutor executor;
};

TEST_F(JobFeedTest, AnEndedJobIsReadInPiecesToItsEnd) {
  const std::int64_t id = AddJob();
  std::vector<ImpactSample> samples;
  double peak = 0.0;
  for (int k = 0; k < 10'000; ++k) {
    samples.push_back(Sample(k));
    peak = std::max(peak, samples.back().plate_force_N);
  }
  store->MarkStarted(id, JobState::kRunning, "host", "0.1.0");
  store->FinishJob(id, JobState::kDone, "", {"{}\n", samples, 0, {}});
  JobFeed feed(*store, executor, id);
  std::vector<ImpactSample> read;
  for (int piece = 0;; ++piece) {
    ASSERT_LT(piece, 10) << "the feed never ended";
    const FeedRead r =
        feed.Read(static_cast<std::int64_t>(read.size()), 4096, std::chrono::milliseconds(0));
    ASSERT_TRUE(r.found);
    EXPECT_EQ(r.state, JobState::kDone);
    EXPECT_EQ(r.progress.peak_plate_force_N, peak);  // over the whole series, not the piece
    read.insert(read.end(), r.samples.begin(), r.samples.end());
    if (r.ended) break;
    EXPECT_EQ(r.samples.size(), 4096u);  // (a piece short of the maximum is the last)
  }
  ASSERT_EQ(read.size(), samples.size());
  for (std::size_t k = 0; k < read.size(); ++k)
    ASSERT_EQ(read[k].plate_force_N, samples[k].plate_force_N) << k;
}

// `dembuf list` showed "preparing_bed" beside the stage "queued 0%": a started job's stage is
// its state until the run reports one of its own.
TEST(LiveJob, ItsStageIsItsStateUntilTheRunReportsOne) {
  LiveJob live(1);
  EXPECT_EQ(live.Progress().stage, "queued");
  live.SetState(JobState::kPreparingBed);
  EXPECT_EQ(live.Progress().stage, "preparing_bed");
  live.SetProgress("bed: settling", 0.1, 0.0, 0);
  live.SetState(JobState::kRunning);
  EXPECT_EQ(live.Progress().stage, "bed: settling");
}

TEST_F(JobFeedTest, ARunningJobIsReadFromTheStoreThenLiveThenToItsEnd) {
  const auto running = AddRunningJob();
  const std::int64_t id = running.first;
  const std::shared_ptr<LiveJob> live = running.second;
  // 1500 samples: the first 1000 already stored by the worker, the rest still in memory.
  for (int k = 0; k < 1500; ++k) live->Append(Sample(k));
  auto [first, unstored] = live->UnstoredSamples();
  store->AppendSeries(id, first, {unstored.begin(), unstored.begin() + 1000});
  live->Stored(1000);

  JobFeed feed(*store, executor, id);
  FeedRead r = feed.Read(0, 4096, std::chrono::milliseconds(0));
  EXPECT_EQ(r.state, JobState::kRunning);
  ASSERT_EQ(r.samples.size(), 1000u);  // the stored ones, from the store
  EXPECT_FALSE(r.ended);
  r = feed.Read(1000, 4096, std::chrono::milliseconds(0));
  ASSERT_EQ(r.samples.size(), 500u);  // the rest, live
  EXPECT_EQ(r.samples.front().plate_force_N, Sample(1000).plate_force_N);
  EXPECT_FALSE(r.ended);

  // Nothing new: the read waits, and returns as soon as a sample comes.
  std::jthread worker([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    live->Append(Sample(1500));
  });
  const auto before = std::chrono::steady_clock::now();
  r = feed.Read(1500, 4096, std::chrono::seconds(10));
  EXPECT_LT(std::chrono::steady_clock::now() - before, std::chrono::seconds(5));
  ASSERT_EQ(r.samples.size(), 1u);
  worker.join();

  // The end: stored, then the live job dropped, as the executor does.
  auto [rest_first, rest] = live->UnstoredSamples();
  // Its summary's peak (of every step) is above every sample's: the ended job says it, live
  // and stored alike (watch ended on the samples' 3554 N where the summary said 3559.3).
  store->FinishJob(id, JobState::kDone, "",
                   {"{\"peak_plate_force_N\": 1e6}\n", rest, rest_first, {}});
  live->End(JobState::kDone);
  r = feed.Read(1501, 4096, std::chrono::milliseconds(0));
  EXPECT_TRUE(r.ended);
  EXPECT_EQ(r.state, JobState::kDone);
  EXPECT_EQ(r.progress.peak_plate_force_N, 1e6);
  executor.live.clear();
  r = feed.Read(0, 4096, std::chrono::milliseconds(0));
  EXPECT_EQ(r.samples.size(), 1501u);
  EXPECT_TRUE(r.ended);
  EXPECT_EQ(r.progress.peak_plate_force_N, 1e6);
}

TEST_F(JobFeedTest, AQueuedJobWaitsAndAMissingOneIsNotFound) {
  const std::int64_t id = AddJob();
  JobFeed feed(*store, executor, id);
  const auto before = std::chrono::steady_clock::now();
  FeedRead r = feed.Read(0, 10, std::chrono::milliseconds(300));
  EXPECT_GE(std::chrono::steady_clock::now() - before, std::chrono::milliseconds(300));
  EXPECT_TRUE(r.found);
  EXPECT_EQ(r.state, JobState::kQueued);
  EXPECT_TRUE(r.samples.empty());
  EXPECT_FALSE(r.ended);
  JobFeed none(*store, executor, id + 100);
  EXPECT_FALSE(none.Read(0, 10, std::chrono::milliseconds(0)).found);
}

TEST_F(JobFeedTest, ASweepsPointsAreItsDoneJobsOverTheSeeds) {
  SweepRecord sweep{
      0, "ada", "speeds", {{"projectile.speed_m_s", {"1", "2"}}, {"bed.seed", {"1", "2"}}}, ""};
  std::vector<JobRecord> jobs(4);
  const std::vector<std::vector<std::string>> values = {
      {"1", "1"}, {"1", "2"}, {"2", "1"}, {"2", "2"}};
  for (std::size_t k = 0; k < jobs.size(); ++k) {
    jobs[k].owner = "ada";
    jobs[k].scene_toml = "x";
    jobs[k].sweep_index = static_cast<int>(k);
    jobs[k].sweep_values = values[k];
  }
  store->AddSweep(sweep, jobs);
  const double p[] = {100.0, 110.0, 300.0};
  for (int k = 0; k < 3; ++k)
    store->FinishJob(jobs[k].id, JobState::kDone, "",
                     {"{\"P_N\": " + std::to_string(p[k]) + ", \"lambda\": 0.5}\n", {}, 0, {}});
  store->MarkStarted(jobs[3].id, JobState::kRunning, "host", "0.1.0");
  const nlohmann::json json = web::SweepJson(*store, sweep);
  EXPECT_EQ(json["jobs_total"], 4);
  EXPECT_EQ(json["jobs_by_state"]["done"], 3);
  EXPECT_EQ(json["jobs_by_state"]["running"], 1);
  EXPECT_EQ(json["axes"][0]["unit"], "m/s");
  ASSERT_EQ(json["points"].size(), 2u);
  const nlohmann::json& slow = json["points"][0];
  EXPECT_EQ(slow["projectile.speed_m_s"], 1);  // a number, as in sweep.csv (it was "1")
  EXPECT_EQ(json["axes"][0]["values"], nlohmann::json({1, 2}));
  EXPECT_EQ(json["jobs"][0]["values"], nlohmann::json({1, 1}));
  // The points are the study layer's, in points.csv's flat shape (they were nested here).
  EXPECT_EQ(json["points"], nlohmann::json::parse(SweepAggregatesJson(
                                sweep, store->SweepResults(sweep.id)))["points"]);
  EXPECT_EQ(slow["runs"], 2);
  EXPECT_DOUBLE_EQ(slow["P_N"].get<double>(), 105.0);
  EXPECT_NEAR(slow["P_N_sd"].get<double>(), std::sqrt(50.0), 1e-9);  // sample sd of 100, 110
  EXPECT_EQ(slow["P_N_n"], 2);
  // The running job counts among the point's runs, in no metric: one done, no spread yet.
  const nlohmann::json& fast = json["points"][1];
  EXPECT_EQ(fast["runs"], 2);
  EXPECT_EQ(fast["P_N_n"], 1);
  EXPECT_TRUE(fast["P_N_sd"].is_null());
  EXPECT_TRUE(json["Hc_m"].is_null());  // not a thickness sweep
}

TEST_F(JobFeedTest, AJobsPeakIsItsSummarysOrElseTheRunningJobs) {
  const auto running = AddRunningJob();
  const std::int64_t id = running.first;
  const std::shared_ptr<LiveJob> live = running.second;
  EXPECT_TRUE(
      web::JobJson(*store, executor, *store->GetJob(id), false)["peak_plate_force_N"].is_null());
  live->Append(Sample(100));
  EXPECT_EQ(web::JobJson(*store, executor, *store->GetJob(id), false)["peak_plate_force_N"],
            Sample(100).plate_force_N);
  executor.live.clear();
  store->FinishJob(id, JobState::kDone, "",
                   {"{\"peak_plate_force_N\": 13.25, \"P_N\": 13.0}\n", {}, 0, {}});
  // Done: the summary's, in the listing (which reads no summaries) as in the details.
  for (bool details : {false, true}) {
    const nlohmann::json json = web::JobJson(*store, executor, *store->GetJob(id), details);
    EXPECT_EQ(json["peak_plate_force_N"], 13.25);
    EXPECT_EQ(json["progress"]["peak_plate_force_N"], 13.25);
    EXPECT_EQ(json["P_N"], 13.0);
    EXPECT_EQ(json["state"], "done");
  }
}

TEST(WebViews, SamplesAreExactColumns) {
  // The batch's text is JSON, every double exact, a value that is not finite null.
  ImpactSample odd = Sample(42);
  odd.projectile_z_m = std::nan("");
  odd.wall_force_z_N = 1.0 / 3.0;
  const nlohmann::json batch =
      nlohmann::json::parse(web::SamplesJson(40, {Sample(40), Sample(41), odd}));
  EXPECT_EQ(batch["first"], 40);
  ASSERT_EQ(batch["t_s"].size(), 3u);
  EXPECT_EQ(batch["t_s"][1].get<double>(), Sample(41).t_s);
  EXPECT_EQ(batch["plate_force_N"][0].get<double>(), Sample(40).plate_force_N);
  EXPECT_EQ(batch["wall_force_z_N"][2].get<double>(), 1.0 / 3.0);
  EXPECT_TRUE(batch["proj_z_m"][2].is_null());
  EXPECT_EQ(batch["proj_force_z_N"][0].get<double>(), Sample(40).projectile_force_z_N);
  EXPECT_EQ(nlohmann::json::parse(web::SamplesJson(0, {}))["t_s"].size(), 0u);
  // Every column of plate_force.csv, and no other (the stream lacked proj_vz_m_s).
  std::vector<std::string> keys;
  for (const auto& [key, value] : batch.items())
    if (key != "first") keys.push_back(key);
  std::vector<std::string> columns;
  for (const report::SampleColumn& c : report::SampleColumns()) columns.push_back(c.name);
  std::sort(keys.begin(), keys.end());
  std::sort(columns.begin(), columns.end());
  EXPECT_EQ(keys, columns);
  EXPECT_EQ(batch["proj_vz_m_s"][0].get<double>(), Sample(40).projectile_vz_m_s);
}

TEST(WebSessions, ASessionNamesItsTokenUntilClosedOrExpired) {
  web::Sessions sessions(std::chrono::seconds(3600), 2);
  const std::string a = sessions.Open("hash-a");
  EXPECT_EQ(a.size(), 64u);
  EXPECT_EQ(sessions.TokenHash(a), "hash-a");
  EXPECT_FALSE(sessions.TokenHash("a guess"));
  sessions.Close(a);
  EXPECT_FALSE(sessions.TokenHash(a));
  // Full: the oldest session goes.
  const std::string b = sessions.Open("hash-b");
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  const std::string c = sessions.Open("hash-c");
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  const std::string d = sessions.Open("hash-d");
  EXPECT_FALSE(sessions.TokenHash(b));
  EXPECT_EQ(sessions.TokenHash(c), "hash-c");
  EXPECT_EQ(sessions.TokenHash(d), "hash-d");
  web::Sessions brief(std::chrono::seconds(0));
  EXPECT_FALSE(brief.TokenHash(brief.Open("hash")));
}

TEST(WebSessions, OneUsersLoginsPushOutOnlyTheirOwnSessions) {
  // 10,000 logins of one user evicted every other user's session (one shared cap).
  web::Sessions sessions(std::chrono::seconds(3600), 100, 4);
  const std::string ada = sessions.Open("hash-ada");
  std::vector<std::string> eve;
  for (int k = 0; k < 1000; ++k) eve.push_back(sessions.Open("hash-eve"));
  EXPECT_EQ(sessions.TokenHash(ada), "hash-ada");
  int eve_live = 0;
  for (const std::string& id : eve) eve_live += sessions.TokenHash(id).has_value();
  EXPECT_EQ(eve_live, 4);
  EXPECT_EQ(sessions.TokenHash(eve.back()), "hash-eve");  // the newest are kept
}

TEST(StreamLimits, PerUserAndInAllAndGivenBack) {
  StreamLimits limits(2, 3, "event streams", "http_max_streams");
  const Caller ada{"ada", false, true, "hash-ada"}, local{"local", true, false, ""};
  std::string why;
  auto first = limits.Take(ada, &why);
  auto second = limits.Take(ada, &why);
  ASSERT_TRUE(first && second);
  EXPECT_FALSE(limits.Take(ada, &why));
  EXPECT_NE(why.find("at most 2 per user"), std::string::npos) << why;
  auto third = limits.Take(local, &why);  // no token: only the total counts
  ASSERT_TRUE(third);
  EXPECT_FALSE(limits.Take(local, &why));
  EXPECT_NE(why.find("http_max_streams"), std::string::npos) << why;
  EXPECT_EQ(limits.open(), 3);
  first.reset();
  EXPECT_EQ(limits.open(), 2);
  EXPECT_TRUE(limits.Take(ada, &why));
}

TEST(HttpAddress, APortAloneIsOnLoopbackAndAnythingElseIsNamed) {
  EXPECT_EQ(HttpAddress("8080"), "127.0.0.1:8080");
  EXPECT_EQ(HttpAddress("0.0.0.0:8080"), "0.0.0.0:8080");
  EXPECT_EQ(HttpAddress("[::1]:0"), "[::1]:0");
  for (const char* bad : {"", "x", ":8080", "host:", "host:99999", "123456", "host:8o"}) {
    try {
      HttpAddress(bad);
      ADD_FAILURE() << bad << " accepted";
    } catch (const ConfigError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("http: ", 0), 0u) << e.what();
    }
  }
}

}  // namespace
}  // namespace dembuf::server
