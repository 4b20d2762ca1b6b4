// The Slurm executor's dealings with Slurm's command-line tools, without a cluster: what it
// asks (sbatch's arguments) and how it reads the answers, which are untrusted text. The
// executor against a real one-node Slurm is tests/slurm/executor_test.sh.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "../engine/temp_path.h"
#include "dembuf/study/files/run_output.h"
#include "dembuf/study/files/snapshot_report.h"
#include "dembuf/study/spawn/program.h"
#include "jobs/slurm.h"
#include "process/config.h"

namespace dembuf::server {
namespace {

using slurm::JobStatus;

TEST(Slurm, ReadsSqueueLinesAndLeavesOutWhatDoesNotParse) {
  const std::vector<JobStatus> jobs = slurm::ParseSqueue(
      "12|dembuf-0a1b2c3d-7|RUNNING|None|node01\n"
      "13|dembuf-0a1b2c3d-8|PENDING|Dependency|\n"
      "x|not-a-job|RUNNING|None|node01\n"            // no id
      "14|dembuf-0a1b2c3d-9|RUN NING|None|node01\n"  // not a state word
      "15|two|fields\n"
      "16|dembuf-0a1b2c3d-10|TIMEOUT|TimeLimit|node02");
  ASSERT_EQ(jobs.size(), 3u);
  EXPECT_EQ(jobs[0].id, 12);
  EXPECT_EQ(jobs[0].name, "dembuf-0a1b2c3d-7");
  EXPECT_EQ(jobs[0].state, "RUNNING");
  EXPECT_EQ(jobs[0].node, "node01");
  EXPECT_EQ(jobs[1].reason, "Dependency");
  EXPECT_EQ(jobs[2].state, "TIMEOUT");
}

TEST(Slurm, ReadsScontrolsOneLineForm) {
  const auto job = slurm::ParseScontrolJob(
      "JobId=42 JobName=dembuf-0a1b2c3d-3 UserId=lab(1000) JobState=OUT_OF_MEMORY "
      "Reason=OutOfMemory Dependency=(null) NodeList=node07 BatchHost=node07");
  ASSERT_TRUE(job);
  EXPECT_EQ(job->id, 42);
  EXPECT_EQ(job->name, "dembuf-0a1b2c3d-3");
  EXPECT_EQ(job->state, "OUT_OF_MEMORY");
  EXPECT_EQ(job->reason, "OutOfMemory");
  EXPECT_EQ(job->node, "node07");
  EXPECT_FALSE(slurm::ParseScontrolJob("slurm_load_jobs error: Invalid job id specified"));
}

TEST(Slurm, ReadsTheJobIdSbatchPrints) {
  EXPECT_EQ(slurm::ParseSbatchId("123\n"), 123);
  EXPECT_EQ(slurm::ParseSbatchId("123;cluster\n"), 123);
  EXPECT_EQ(slurm::ParseSbatchId("sbatch: warning: something\n77\n"), 77);
  EXPECT_FALSE(slurm::ParseSbatchId("sbatch: error: Batch job submission failed\n"));
  EXPECT_FALSE(slurm::ParseSbatchId("-5"));
  EXPECT_FALSE(slurm::ParseSbatchId(""));
}

TEST(Slurm, FinalStatesAreTheOnesThatDoNotRunAgain) {
  for (const char* s : {"COMPLETED", "FAILED", "CANCELLED", "TIMEOUT", "OUT_OF_MEMORY", "NODE_FAIL",
                        "PREEMPTED", "BOOT_FAIL", "DEADLINE"})
    EXPECT_TRUE(slurm::IsFinalState(s)) << s;
  for (const char* s : {"PENDING", "RUNNING", "COMPLETING", "CONFIGURING", "SUSPENDED", ""})
    EXPECT_FALSE(slurm::IsFinalState(s)) << s;
}

// sbatch says "Batch job submission failed" when slurmctld is down too: such a job must wait
// for the cluster, not fail (it failed, with the cluster down for a minute).
TEST(Slurm, AControllerThatCannotBeReachedIsToldFromARefusal) {
  using slurm::SlurmUnreachable;
  EXPECT_TRUE(SlurmUnreachable(
      "sbatch failed (exit 1): sbatch: error: Batch job submission failed: Unable to contact "
      "slurm controller (connect failure)"));
  EXPECT_TRUE(SlurmUnreachable(
      "sbatch failed (exit 1): sbatch: error: s_p_parse_file: unable to status file "
      "/etc/slurm/slurm.conf: No such file or directory"));
  EXPECT_TRUE(SlurmUnreachable("sbatch did not answer in 60 s"));
  EXPECT_TRUE(SlurmUnreachable("squeue: slurm_load_jobs error: Socket timed out on send/recv"));
  EXPECT_FALSE(SlurmUnreachable(
      "sbatch failed (exit 1): sbatch: error: Batch job submission failed: Invalid partition "
      "name specified"));
  EXPECT_FALSE(SlurmUnreachable(
      "sbatch failed (exit 1): sbatch: error: Batch job submission failed: Requested node "
      "configuration is not available"));
}

TEST(Slurm, TimeLimitsInEverySlurmForm) {
  EXPECT_EQ(slurm::ParseTimeLimit("30"), 30 * 60);
  EXPECT_EQ(slurm::ParseTimeLimit("0:05"), 5);
  EXPECT_EQ(slurm::ParseTimeLimit("2:00:00"), 7200);
  EXPECT_EQ(slurm::ParseTimeLimit("1-00"), 86400);
  EXPECT_EQ(slurm::ParseTimeLimit("1-02:30"), 86400 + 2 * 3600 + 30 * 60);
  EXPECT_EQ(slurm::ParseTimeLimit("1-00:00:10"), 86410);
  for (const char* bad : {"", "0", "abc", "1:2:3:4", "-5", "1-", "400-00", "5 min", "1e3"})
    EXPECT_FALSE(slurm::ParseTimeLimit(bad)) << bad;
  EXPECT_EQ(slurm::FormatTimeLimit(5), "0:05");
  EXPECT_EQ(slurm::FormatTimeLimit(7265), "121:05");
}

TEST(Slurm, SbatchGetsEveryValueAsOneArgumentAndTheCommandQuoted) {
  slurm::Settings settings;
  settings.partition = "short";
  settings.account = "lab";
  settings.extra_args = {"--qos=normal"};
  slurm::Submission job;
  job.name = "dembuf-0a1b2c3d-7";
  job.folder = "/shared/jobs/it's here";
  job.log = "/shared/jobs/it's here/slurm.log";
  job.cpus = 2;
  job.mem_mb = 700;
  job.time_s = 90;
  job.after_ok = {11, 12};
  job.command = {"/opt/dembuf", "run", "/shared/a b/scene.toml", "$(rm -rf ~)"};
  const std::vector<std::string> args = slurm::SbatchArgs(settings, job);
  const std::vector<std::string> expected = {
      "sbatch",
      "--parsable",
      "--job-name=dembuf-0a1b2c3d-7",
      "--chdir=/shared/jobs/it's here",
      "--output=/shared/jobs/it's here/slurm.log",
      "--cpus-per-task=2",
      "--mem=700M",
      "--time=1:30",
      "--partition=short",
      "--account=lab",
      "--dependency=afterok:11:12",
      "--kill-on-invalid-dep=yes",
      "--qos=normal",
      "--wrap=exec '/opt/dembuf' 'run' '/shared/a b/scene.toml' '$(rm -rf ~)'"};
  EXPECT_EQ(args, expected);
}

TEST(Slurm, AQuotedWordReachesTheProgramUnchanged) {
  // Through a real shell: every awkward character arrives as it was.
  const std::string word = "it's $HOME `id` \"x\" \\ ; | & * \n end";
  const ProgramResult echo =
      RunProgram({"sh", "-c", "printf '%s' " + ShellQuote(word)}, std::chrono::seconds(10));
  EXPECT_EQ(echo.exit_code, 0);
  EXPECT_EQ(echo.output, word);
}

TEST(Slurm, ACommandThatHangsIsKilledAtItsTimeout) {
  const auto start = std::chrono::steady_clock::now();
  const ProgramResult sleeper = RunProgram({"sleep", "30"}, std::chrono::milliseconds(300));
  EXPECT_TRUE(sleeper.timed_out);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
  EXPECT_EQ(RunProgram({"no-such-program-here"}).exit_code, 127);
}

TEST(SlurmConfig, TheSlurmTableIsReadAndChecked) {
  ServerConfig config;
  LoadConfigText(
      "executor = \"slurm\"\n[slurm]\nwork_dir = \"/shared/dembuf\"\npartition = \"short\"\n"
      "cpus_per_job = 4\ntime_limit = \"2:00:00\"\nextra_args = [\"--qos=normal\"]\n",
      "test.toml", config);
  ValidateConfig(config);
  EXPECT_EQ(config.executor, "slurm");
  EXPECT_EQ(config.slurm.work_dir, "/shared/dembuf");
  EXPECT_EQ(config.slurm.cpus_per_job, 4);
  EXPECT_EQ(config.slurm.extra_args, std::vector<std::string>{"--qos=normal"});

  auto refused = [](const std::string& text) {
    ServerConfig c;
    try {
      LoadConfigText(text, "test.toml", c);
      ValidateConfig(c);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(refused("executor = \"cloud\"\n").find("executor"), std::string::npos);
  EXPECT_NE(refused("executor = \"slurm\"\n").find("slurm.work_dir"), std::string::npos);
  const std::string base = "executor = \"slurm\"\n[slurm]\nwork_dir = \"/s\"\n";
  EXPECT_NE(refused(base + "time_limit = \"soon\"\n").find("slurm.time_limit"), std::string::npos);
  EXPECT_NE(refused(base + "cpus_per_job = 0\n").find("slurm.cpus_per_job"), std::string::npos);
  EXPECT_NE(refused(base + "partition = \"a;b\"\n").find("slurm.partition"), std::string::npos);
  EXPECT_NE(refused(base + "extra_args = [\"--wrap=id\"]\n").find("slurm.extra_args"),
            std::string::npos);
  EXPECT_NE(refused(base + "nodes = 3\n").find("slurm.nodes"), std::string::npos);
}

}  // namespace
}  // namespace dembuf::server
