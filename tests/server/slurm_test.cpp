// The Slurm executor's dealings with Slurm's command-line tools, without a cluster: what it
// asks (sbatch's arguments) and how it reads the answers, which are untrusted text. The
// executor against a real one-node Slurm is tests/slurm/executor_test.sh.
#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

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
      "12|N/A|dembuf-0a1b2c3d-7|RUNNING|None|node01\n"
      "13|N/A|dembuf-0a1b2c3d-8|PENDING|Dependency|\n"
      "x|N/A|not-a-job|RUNNING|None|node01\n"            // no id
      "14|N/A|dembuf-0a1b2c3d-9|RUN NING|None|node01\n"  // not a state word
      "15|two|fields\n"
      "17|3-9%2|dembuf-0a1b2c3d-array-5|PENDING|None|\n"  // tasks not one per line (no -r)
      "16|N/A|dembuf-0a1b2c3d-10|TIMEOUT|TimeLimit|node02\n"
      "20|4|dembuf-0a1b2c3d-array-30|RUNNING|None|node03");
  ASSERT_EQ(jobs.size(), 4u);
  EXPECT_EQ(jobs[0].id, 12);
  EXPECT_EQ(jobs[0].task, -1);
  EXPECT_EQ(jobs[0].name, "dembuf-0a1b2c3d-7");
  EXPECT_EQ(jobs[0].state, "RUNNING");
  EXPECT_EQ(jobs[0].node, "node01");
  EXPECT_EQ(jobs[1].reason, "Dependency");
  EXPECT_EQ(jobs[2].state, "TIMEOUT");
  // A task of an array: the array's id and the task's index.
  EXPECT_EQ(jobs[3].id, 20);
  EXPECT_EQ(jobs[3].task, 4);
  EXPECT_EQ(jobs[3].node, "node03");
}

TEST(Slurm, ReadsScontrolsOneLineForm) {
  const auto jobs = slurm::ParseScontrolJob(
      "JobId=42 JobName=dembuf-0a1b2c3d-3 UserId=lab(1000) JobState=OUT_OF_MEMORY "
      "Reason=OutOfMemory Dependency=(null) NodeList=node07 BatchHost=node07");
  ASSERT_EQ(jobs.size(), 1u);
  const JobStatus& job = jobs[0];
  EXPECT_EQ(job.id, 42);
  EXPECT_EQ(job.task, -1);
  EXPECT_EQ(job.name, "dembuf-0a1b2c3d-3");
  EXPECT_EQ(job.state, "OUT_OF_MEMORY");
  EXPECT_EQ(job.reason, "OutOfMemory");
  EXPECT_EQ(job.node, "node07");
  EXPECT_TRUE(slurm::ParseScontrolJob("slurm_load_jobs error: Invalid job id specified").empty());
}

TEST(Slurm, ScontrolsArrayTasksAreKnownByTheArraysIdAndTheirIndex) {
  // A task that runs has a job id of its own; the tasks that still wait share one line.
  const auto running = slurm::ParseScontrolJob(
      "JobId=51 ArrayJobId=50 ArrayTaskId=1 JobName=dembuf-0a1b2c3d-array-9 JobState=RUNNING "
      "Reason=None NodeList=node01");
  ASSERT_EQ(running.size(), 1u);
  EXPECT_EQ(running[0].id, 50);
  EXPECT_EQ(running[0].task, 1);
  const auto waiting = slurm::ParseScontrolJob(
      "JobId=50 ArrayJobId=50 ArrayTaskId=2-4,7%2 JobName=dembuf-0a1b2c3d-array-9 "
      "JobState=PENDING Reason=JobArrayTaskLimit NodeList=(null)");
  ASSERT_EQ(waiting.size(), 4u);
  for (const JobStatus& task : waiting) {
    EXPECT_EQ(task.id, 50);
    EXPECT_EQ(task.reason, "JobArrayTaskLimit");
  }
  EXPECT_EQ(waiting[0].task, 2);
  EXPECT_EQ(waiting[3].task, 7);
  // A task list that is not one, or one too long to be an array's, is not taken.
  EXPECT_TRUE(
      slurm::ParseScontrolJob("JobId=50 ArrayJobId=50 ArrayTaskId=x JobState=PENDING").empty());
  EXPECT_TRUE(
      slurm::ParseScontrolJob("JobId=50 ArrayJobId=50 ArrayTaskId=0-999999 JobState=PENDING")
          .empty());
}

TEST(Slurm, ArrayIndexesAreWrittenAsRanges) {
  EXPECT_EQ(slurm::FormatArrayIndexes({0, 1, 2, 3}), "0-3");
  EXPECT_EQ(slurm::FormatArrayIndexes({9, 0, 1, 5, 6, 3}), "0-1,3,5-6,9");
  EXPECT_EQ(slurm::FormatArrayIndexes({4}), "4");
  for (const std::vector<int>& indexes :
       {std::vector<int>{0, 1, 2, 3}, std::vector<int>{0, 1, 3, 5, 6, 9}, std::vector<int>{4}})
    EXPECT_EQ(slurm::ParseArrayIndexes(slurm::FormatArrayIndexes(indexes)), indexes);
  EXPECT_EQ(slurm::ParseArrayIndexes("3-5%2"), (std::vector<int>{3, 4, 5}));
  EXPECT_EQ(slurm::ParseArrayIndexes("1-9:4,12"), (std::vector<int>{1, 5, 9, 12}));
  for (const char* bad : {"", "a", "5-3", "1,,2", "-1", "1-", "0-100000", "1-9:0", "1-3..."})
    EXPECT_FALSE(slurm::ParseArrayIndexes(bad)) << bad;
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

// A job whose id the daemon lost is followed in the Slurm job of its name. squeue may list
// several (a job sent again when its first sbatch said no id): the first listed was taken,
// though only the last sbatch's result passes the job's nonce. And a bed job cancelled a moment
// ago is COMPLETING, one whose dependency failed pends for ever: followed, either failed the job
// it was given to.
TEST(Slurm, ALostJobIsFollowedInItsNewestCopyAndAnEndingBedJobInNone) {
  using slurm::Liveness;
  const auto of = [](const char* state, const char* reason = "None") {
    return slurm::LivenessOf({1, -1, "x", state, reason, ""});
  };
  EXPECT_EQ(of("PENDING"), Liveness::kMayRun);
  EXPECT_EQ(of("PENDING", "Dependency"), Liveness::kMayRun);
  EXPECT_EQ(of("SUSPENDED"), Liveness::kMayRun);
  EXPECT_EQ(of("PENDING", "DependencyNeverSatisfied"), Liveness::kEnding);
  EXPECT_EQ(of("COMPLETING"), Liveness::kEnding);
  EXPECT_EQ(of("CANCELLED"), Liveness::kEnded);
  const std::vector<slurm::JobStatus> listed = {{12, -1, "other", "RUNNING", "None", "n1"},
                                                {10, -1, "mine", "RUNNING", "None", "n1"},
                                                {11, -1, "mine", "COMPLETED", "None", "n1"},
                                                {8, -1, "mine", "RUNNING", "None", "n1"},
                                                {9, -1, "mine", "COMPLETING", "None", "n1"}};
  const auto mine = [](const slurm::JobStatus& s) { return s.name == "mine"; };
  const auto chosen = [&](const std::vector<slurm::JobStatus>& jobs, Liveness least) {
    const slurm::JobStatus* job = slurm::ChooseCopy(jobs, mine, least);
    return job ? job->id : 0;
  };
  EXPECT_EQ(chosen(listed, Liveness::kEnded), 11);  // at start-up: the newest, ended or not
  EXPECT_EQ(chosen(listed, Liveness::kEnding), 10);
  EXPECT_EQ(chosen(listed, Liveness::kMayRun), 10);
  const std::vector<slurm::JobStatus> ending = {
      {9, -1, "mine", "COMPLETING", "None", "n1"},
      {8, -1, "mine", "PENDING", "DependencyNeverSatisfied", ""}};
  EXPECT_EQ(chosen(ending, Liveness::kMayRun), 0);  // a bed's: neither will prepare it
  EXPECT_EQ(chosen(ending, Liveness::kEnding), 9);
  EXPECT_EQ(chosen({listed[0]}, Liveness::kEnded), 0);
  // The copies to cancel: the live ones but the followed, each once (a line printed twice
  // must not cancel the followed job), and no more than the bound.
  std::vector<slurm::JobStatus> twice = listed;
  twice.push_back(listed[1]);
  twice.push_back(listed[3]);
  const std::vector<slurm::JobKey> others = {{8, -1}};
  EXPECT_EQ(slurm::OtherLiveCopies(twice, mine, listed[1]), others);
  std::vector<slurm::JobStatus> many;
  for (int id = 100; id < 200; ++id) many.push_back({id, -1, "mine", "PENDING", "None", ""});
  EXPECT_EQ(slurm::OtherLiveCopies(many, mine, many.back()).size(), slurm::kMaxOtherCopies);
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

TEST(Slurm, AnArraysTasksEachRunTheirOwnJobAndCarryTheirUser) {
  slurm::Settings settings;
  settings.account = "lab";
  slurm::Submission job;
  job.name = "dembuf-0a1b2c3d-array-40";
  job.folder = "/shared/jobs/a";
  job.log = "/shared/jobs/a/task-%a.log";
  job.account = "proj-a";  // the user's, over the settings'
  job.wckey = "alice";
  job.comment = "dembuf_user=alice";
  job.array_tasks = {0, 1, 2, 5};
  job.array_base = 40;
  job.array_limit = 2;
  job.command = {"/opt/dembuf", "run", "/shared/it's/d-{job}/scene.toml"};
  const std::vector<std::string> args = slurm::SbatchArgs(settings, job);
  for (const char* arg :
       {"--account=proj-a", "--wckey=alice", "--comment=dembuf_user=alice", "--array=0-2,5%2"})
    EXPECT_NE(std::find(args.begin(), args.end(), arg), args.end()) << arg;
  EXPECT_EQ(std::find(args.begin(), args.end(), "--account=lab"), args.end());
  const std::string wrap = args.back();
  ASSERT_EQ(wrap.rfind("--wrap=", 0), 0u);
  // The shell line as Slurm runs it, task 5: job 45's folder, every other word as it was.
  std::string line = wrap.substr(7);
  const std::size_t exec = line.find(" && exec ");
  ASSERT_NE(exec, std::string::npos) << line;
  line.replace(exec, 9, " && printf '%s|' ");
  const ProgramResult task =
      RunProgram({"sh", "-c", "SLURM_ARRAY_TASK_ID=5; " + line}, std::chrono::seconds(10));
  EXPECT_EQ(task.exit_code, 0);
  EXPECT_EQ(task.output, "/opt/dembuf|run|/shared/it's/d-45/scene.toml|");
}

// Programs named squeue and scontrol in a folder first in PATH, printing `output` and exiting
// with `code`, for as long as the object lives.
class FakeSlurm {
 public:
  FakeSlurm(const std::string& squeue, int squeue_code, const std::string& scontrol,
            int scontrol_code)
      : m_dir(test::TempPath("bin")), m_path(std::getenv("PATH")) {
    std::filesystem::create_directories(m_dir);
    Write("squeue", squeue, squeue_code);
    Write("scontrol", scontrol, scontrol_code);
    setenv("PATH", (m_dir + ":" + m_path).c_str(), 1);
  }
  ~FakeSlurm() { setenv("PATH", m_path.c_str(), 1); }

 private:
  void Write(const std::string& name, const std::string& output, int code) {
    const std::string path = m_dir + "/" + name;
    std::ofstream(path) << "#!/bin/sh\nprintf '%s\\n' " << ShellQuote(output) << "\nexit " << code
                        << "\n";
    std::filesystem::permissions(path, std::filesystem::perms::owner_all);
  }
  std::string m_dir, m_path;
};

// A cluster that cannot be reached says nothing of the jobs: they must not be taken as gone
// (every running job was failed when slurmctld restarted).
TEST(Slurm, AClusterThatDoesNotAnswerSaysNoJobHasGone) {
  slurm::Client client{slurm::Settings{}};
  {
    FakeSlurm down("squeue: error: Unable to contact slurm controller (connect failure)", 1, "", 1);
    EXPECT_THROW(client.Query({12}), slurm::SlurmError);
  }
  {
    // squeue refuses the list (one id unknown); scontrol fails otherwise than "Invalid job id".
    FakeSlurm refusing("slurm_load_jobs error: Invalid job id specified", 1,
                       "slurm_load_jobs error: Socket timed out on send/recv operation", 1);
    EXPECT_THROW(client.Query({12}), slurm::SlurmError);
  }
  {
    FakeSlurm garbled("", 1, "JobId=12 ArrayJobId=12 ArrayTaskId=3-1... JobState=PENDING", 0);
    EXPECT_THROW(client.Query({12}), slurm::SlurmError);
  }
  {
    FakeSlurm forgotten("slurm_load_jobs error: Invalid job id specified", 1,
                        "slurm_load_jobs error: Invalid job id specified", 1);
    EXPECT_TRUE(client.Query({12}).empty());  // Slurm's own word: gone
  }
  FakeSlurm known("", 1, "JobId=13 ArrayJobId=12 ArrayTaskId=1 JobName=x JobState=RUNNING", 0);
  const auto found = client.Query({12});
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found.begin()->first, (slurm::JobKey{12, 1}));
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

// A killed command used to leave what it had started running: a script's own commands, which
// kept the cluster's tools busy (or printed on) after the daemon had given up on it.
TEST(Slurm, AKilledCommandTakesWhatItStartedWithIt) {
  const std::string pid_file = test::TempPath("pid");
  const ProgramResult killed =
      RunProgram({"sh", "-c", "sleep 60 & echo $! > " + ShellQuote(pid_file) + "; wait"},
                 std::chrono::seconds(2));
  EXPECT_TRUE(killed.timed_out);
  std::ifstream in(pid_file);
  int started = 0;
  ASSERT_TRUE(in >> started) << "the script did not say its sleep's pid";
  // Gone, or a zombie waiting for its reaper (a container's first process may never reap it).
  const auto running = [&] {
    std::ifstream stat("/proc/" + std::to_string(started) + "/stat");
    std::string pid, name, state;
    return stat >> pid >> name >> state && state != "Z";
  };
  for (int k = 0; k < 50 && running(); ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_FALSE(running()) << "the script's sleep (pid " << started << ") outlived it";
}

// The timeout used to count only while the program's output was open: one that closed it and
// ran on was waited for without end, and one that left its process group was not killed. Each
// held the daemon's pass, and every cancel behind it.
TEST(Slurm, ACommandIsKilledAtItsTimeoutWhateverItDoesWithItsOutputOrGroup) {
  const std::vector<std::vector<std::string>> hangers = {
      {"sh", "-c", "exec > /dev/null 2>&1; sleep 30"},
      {"python3", "-c",
       "import os, time; os.setpgid(0, os.getpgid(os.getppid())); print('moved', flush=True); "
       "time.sleep(30)"}};
  for (const std::vector<std::string>& args : hangers) {
    const auto start = std::chrono::steady_clock::now();
    const ProgramResult hung = RunProgram(args, std::chrono::seconds(3));
    EXPECT_TRUE(hung.timed_out) << args.back();
    if (args[0] == "python3") {  // it had left the group before the kill
      EXPECT_NE(hung.output.find("moved"), std::string::npos) << hung.output;
    }
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10)) << args.back();
    EXPECT_EQ(hung.exit_code, 128 + SIGKILL) << args.back();
  }
  // A program that ends in time is not taken for one that timed out.
  const ProgramResult quick =
      RunProgram({"sh", "-c", "exec > /dev/null; exit 3"}, std::chrono::seconds(10));
  EXPECT_FALSE(quick.timed_out);
  EXPECT_EQ(quick.exit_code, 3);
}

TEST(Slurm, ACommandThatPrintsWithoutEndIsKilledAtTheOutputBound) {
  // A cluster's command gone wrong (or hostile) must not take the daemon's memory: `yes`
  // prints without end, and is killed once its output would pass the bound.
  const ProgramResult endless =
      RunProgram({"yes", "a line a cluster might print"}, std::chrono::seconds(120));
  EXPECT_TRUE(endless.overflowed);
  EXPECT_FALSE(endless.timed_out);
  EXPECT_LE(endless.output.size(), kMaxProgramOutput);
  EXPECT_GT(endless.output.size(), kMaxProgramOutput / 2);
  EXPECT_EQ(endless.exit_code, 128 + SIGKILL);
  EXPECT_FALSE(RunProgram({"echo", "short"}).overflowed);
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
  EXPECT_NE(refused(base + "extra_args = [\"--account=other\"]\n").find("the daemon's to set"),
            std::string::npos);
  EXPECT_NE(refused(base + "array_tasks_max = 0\n").find("slurm.array_tasks_max"),
            std::string::npos);
  EXPECT_NE(refused(base + "array_limit = -1\n").find("slurm.array_limit"), std::string::npos);
  EXPECT_NE(refused(base + "[slurm.accounts]\n\"a b\" = \"x\"\n").find("slurm.accounts"),
            std::string::npos);
  EXPECT_NE(refused(base + "accounts = {alice = \"x;y\"}\n").find("slurm.accounts.alice"),
            std::string::npos);
  EXPECT_NE(refused(base + "accounts = [\"alice\"]\n").find("a table of strings"),
            std::string::npos);
}

TEST(SlurmConfig, AUsersAccountMapIsReadAndWrittenBack) {
  ServerConfig config;
  LoadConfigText(
      "executor = \"slurm\"\n[slurm]\nwork_dir = \"/s\"\narray_limit = 4\nwckey = true\n"
      "[slurm.accounts]\nalice = \"proj-a\"\n\"b.o.b\" = \"proj-b\"\n",
      "test.toml", config);
  ValidateConfig(config);
  EXPECT_EQ(config.slurm.array_limit, 4);
  EXPECT_TRUE(config.slurm.wckey);
  EXPECT_EQ(config.slurm.accounts,
            (std::map<std::string, std::string>{{"alice", "proj-a"}, {"b.o.b", "proj-b"}}));
  // --check-config's text reads back to the same settings.
  ServerConfig again;
  LoadConfigText(ConfigText(config), "printed", again);
  EXPECT_EQ(again, config);
}

}  // namespace
}  // namespace dembuf::server
