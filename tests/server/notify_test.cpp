// Notifications of a job's or sweep's end: what is owed (the store), what is posted (the
// text, which must not let a user's name ping a channel), where (the hook's URL, read from a
// file only the daemon may read). The posting itself, to a real HTTP server, is
// tests/server/notify_test.sh.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "../engine/temp_path.h"
#include "notify/notifier.h"
#include "process/secret_file.h"
#include "store/store.h"

namespace dembuf::server {
namespace {

namespace fs = std::filesystem;

TEST(Notify, AHooksUrlIsSplitForTheClientAndCheckedWithoutBeingRepeated) {
  const HookAddress hook = ParseHookUrl("https://chat.lab.example:8065/hooks/abc123");
  EXPECT_EQ(hook.origin, "https://chat.lab.example:8065");
  EXPECT_EQ(hook.path, "/hooks/abc123");
  EXPECT_EQ(ParseHookUrl("http://127.0.0.1:9000").path, "/");
  for (const char* bad : {"ftp://x/hook", "chat.lab/hooks/secret123", "https:///hooks/secret123",
                          "https://user:secret123@chat/x", "https://chat/hooks/secret123 x",
                          "https://chat/hooks/secret123\n"}) {
    try {
      ParseHookUrl(bad);
      ADD_FAILURE() << bad << " was taken";
    } catch (const std::invalid_argument& e) {
      // The URL is a secret: the message says what is wrong, not what it was.
      EXPECT_EQ(std::string(e.what()).find("secret123"), std::string::npos) << e.what();
    }
  }
}

TEST(Notify, AUsersTextCannotPingAChannelOrFormatTheMessage) {
  EXPECT_EQ(ChatSafe("E2 thickness 0.02 (seed 3)"), "E2 thickness 0.02 (seed 3)");
  EXPECT_EQ(ChatSafe("@channel <!here> [x](http://evil) `code` *b*"),
            "?channel ??here? ?x?(http: //evil) ?code? ?b?");
  EXPECT_EQ(ChatSafe("line\nbreak"), "line?break");
  EXPECT_EQ(ChatSafe(std::string(300, 'a'), 10), std::string(10, 'a') + "...");
}

JobRecord EndedJob(JobState state) {
  JobRecord job;
  job.id = 12;
  job.owner = "alice";
  job.name = "@here drop";
  job.state = state;
  return job;
}

TEST(Notify, AJobsEndSaysWhatCameOfItAndHowToFetchIt) {
  JobRecord done = EndedJob(JobState::kDone);
  done.peak_plate_force_N = 123.456;
  done.P_N = 45.0;
  EXPECT_EQ(JobEndedText(done, false),
            "dembuf: job 12 \"?here drop\" of alice is done: P = 45 N (dembuf fetch 12)");
  JobRecord failed = EndedJob(JobState::kFailed);
  failed.error = "unstable at t = 1 ms <@U1>";
  EXPECT_EQ(JobEndedText(failed, true),
            "@alice dembuf: job 12 \"?here drop\" of alice failed: unstable at t = 1 ms ??U1? "
            "(dembuf fetch 12)");
  EXPECT_NE(JobEndedText(EndedJob(JobState::kCancelled), false).find("was cancelled"),
            std::string::npos);
  // A user named as the chats name everyone is not mentioned (access "local" takes any name).
  for (const char* everyone : {"channel", "all", "here", "everyone"}) {
    JobRecord job = done;
    job.owner = everyone;
    EXPECT_EQ(JobEndedText(job, true).rfind("dembuf: job 12", 0), 0u) << everyone;
  }
}

TEST(Notify, ASweepsEndCountsItsJobsByState) {
  SweepRecord sweep;
  sweep.id = 7;
  sweep.owner = "bob";
  sweep.name = "E2 curve";
  EXPECT_EQ(SweepEndedText(sweep, {{"done", 11}, {"failed", 1}}, false),
            "dembuf: sweep 7 \"E2 curve\" of bob has ended: 11 done, 1 failed of 12 jobs "
            "(dembuf fetch --sweep 7)");
  // The body is JSON whatever the text holds.
  EXPECT_EQ(nlohmann::json::parse(HookBody("a \"quoted\" \\ text")).at("text"),
            "a \"quoted\" \\ text");
}

class NotificationStore : public testing::Test {
 protected:
  std::string path = test::TempPath("store.db");
};

TEST_F(NotificationStore, AJobIsOwedItsNotificationOnceItHasEndedAndNotAfterItIsSent) {
  Store store(path);
  JobRecord wanted;
  wanted.owner = "alice";
  wanted.notify = true;
  store.AddJob(wanted);
  JobRecord quiet;
  quiet.owner = "alice";
  store.AddJob(quiet);
  EXPECT_TRUE(store.DueNotifications().empty());  // queued: not yet
  store.FinishJob(quiet.id, JobState::kDone, "", {});
  EXPECT_TRUE(store.DueNotifications().empty());  // ended, but asked for none
  store.FinishJob(wanted.id, JobState::kFailed, "why", {});
  const std::vector<NotificationRecord> due = store.DueNotifications();
  ASSERT_EQ(due.size(), 1u);
  EXPECT_EQ(due[0].job_id, wanted.id);
  EXPECT_EQ(due[0].sweep_id, 0);
  EXPECT_EQ(due[0].owner, "alice");
  store.EndNotification(due[0].id, "sent");
  EXPECT_TRUE(store.DueNotifications().empty());
}

TEST_F(NotificationStore, ASweepIsOwedOneNotificationWhenItsLastJobHasEnded) {
  Store store(path);
  SweepRecord sweep;
  sweep.owner = "bob";
  sweep.notify = true;
  std::vector<JobRecord> jobs(3);
  for (JobRecord& job : jobs) {
    job.owner = "bob";
    job.notify = true;  // a sweep's jobs are told of with their sweep, not each
  }
  store.AddSweep(sweep, jobs);
  store.FinishJob(jobs[0].id, JobState::kDone, "", {});
  store.FinishJob(jobs[1].id, JobState::kCancelled, "", {});
  EXPECT_TRUE(store.DueNotifications().empty());
  store.FinishJob(jobs[2].id, JobState::kDone, "", {});
  const std::vector<NotificationRecord> due = store.DueNotifications();
  ASSERT_EQ(due.size(), 1u);
  EXPECT_EQ(due[0].sweep_id, sweep.id);
  EXPECT_EQ(due[0].job_id, 0);
  // A deleted sweep is owed nothing (and its row goes with it).
  store.DeleteJobs({jobs[0].id, jobs[1].id, jobs[2].id}, sweep.id);
  EXPECT_TRUE(store.DueNotifications().empty());
}

std::string Written(const std::string& path, const std::string& text, mode_t mode) {
  std::ofstream(path) << text;
  chmod(path.c_str(), mode);
  return path;
}

TEST(SecretFile, IsReadOnlyWhenNoOtherAccountMayReadOrChangeIt) {
  const std::string url = "https://chat/hooks/secret123";
  EXPECT_EQ(ReadSecretFile("notify_url_file", Written(test::TempPath("ok"), url + "\n", 0600)),
            url);
  EXPECT_EQ(ReadSecretFile("notify_url_file", Written(test::TempPath("group"), url, 0640)), url);
  auto refusal = [&](const std::string& path) {
    try {
      ReadSecretFile("notify_url_file", path);
    } catch (const std::runtime_error& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.find("secret123"), std::string::npos) << what;  // never its contents
      EXPECT_EQ(what.rfind("notify_url_file: ", 0), 0u) << what;
      return what;
    }
    return std::string();
  };
  EXPECT_NE(refusal(Written(test::TempPath("world"), url, 0644)).find("chmod 0640"),
            std::string::npos);
  EXPECT_NE(refusal(Written(test::TempPath("groupw"), url, 0660)).find("mode 0660"),
            std::string::npos);
  const std::string link = test::TempPath("link");
  fs::create_symlink(test::TempPath("ok"), link);
  EXPECT_NE(refusal(link).find("a link"), std::string::npos);
  EXPECT_NE(refusal(test::TempPath("absent")).find("No such file"), std::string::npos);
  EXPECT_NE(refusal(Written(test::TempPath("empty"), "\n", 0600)).find("empty"), std::string::npos);
  EXPECT_NE(refusal(Written(test::TempPath("long"), std::string(5000, 'x'), 0600)).find("longer"),
            std::string::npos);
  // Readable by a group that is not the daemon's (root:users 0640): every user of it.
  if (geteuid() == 0) {
    const std::string other = Written(test::TempPath("othergroup"), url, 0640);
    ASSERT_EQ(chown(other.c_str(), static_cast<uid_t>(-1), getegid() + 1), 0);
    EXPECT_NE(refusal(other).find("may read it, not this daemon's group"), std::string::npos);
  }
  const std::string folder = test::TempPath("folder");
  fs::create_directory(folder);
  EXPECT_NE(refusal(folder).find("not a regular file"), std::string::npos);
}

}  // namespace
}  // namespace dembuf::server
