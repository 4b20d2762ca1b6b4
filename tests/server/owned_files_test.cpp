// The daemon's own files and folders (owned_files.h): what another account, or a cluster node,
// may have left where the daemon reads and writes is refused or not followed.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>

#include "../engine/temp_path.h"
#include "dembuf/study/files/run_output.h"
#include "dembuf/study/files/snapshot_report.h"
#include "store/owned_files.h"

namespace dembuf::server {
namespace {

namespace fs = std::filesystem;

// A fresh folder of this test's, made 0700 as the daemon makes its own.
OwnedFolder MakeFolder(const std::string& name) {
  const fs::path path = test::TempPath(name);
  fs::remove_all(path);
  return OwnedFolder::Open(path, "the test folder", true);
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

std::string Message(const std::function<void()>& call) {
  try {
    call();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "accepted";
}

TEST(OwnedFolder, IsMadeForTheDaemonAlone) {
  const OwnedFolder folder = MakeFolder("made");
  struct stat made {};
  ASSERT_EQ(stat(folder.path().c_str(), &made), 0);
  EXPECT_EQ(made.st_mode & 0777, 0700u);
  const OwnedFolder inner = folder.Folder("jobs", true);
  ASSERT_EQ(stat(inner.path().c_str(), &made), 0);
  EXPECT_EQ(made.st_mode & 0777, 0700u);
  EXPECT_THROW(folder.Folder("../jobs", true), OwnershipError);
  EXPECT_THROW(folder.Folder("absent", false), OwnershipError);
}

// A folder that is not there (a --db in a folder never made) is named with the command that
// makes it for the daemon's account.
TEST(OwnedFolder, AMissingFolderIsNamedWithTheCommandThatMakesIt) {
  const fs::path absent = test::TempPath("never-made");
  fs::remove_all(absent);
  const std::string why = Message([&] { OwnedFolder::Open(absent, "the database folder", false); });
  EXPECT_NE(why.find("the database folder " + absent.string() + " does not exist"),
            std::string::npos)
      << why;
  EXPECT_NE(why.find("install -d -m 0700 -o "), std::string::npos) << why;
  EXPECT_FALSE(fs::exists(absent));
}

// A file only checked (CheckOwned, OpenToRead) may be read-only: the daemon's own file is
// taken, one others may write is not, and an absent one is no error for CheckOwned.
TEST(OwnedFolder, CheckOwnedTakesAReadOnlyFileOfItsOwn) {
  const OwnedFolder folder = MakeFolder("checked");
  EXPECT_NO_THROW(folder.CheckOwned("absent.db"));
  WriteText(folder.path() / "read-only.db", "x");
  chmod((folder.path() / "read-only.db").c_str(), 0400);
  EXPECT_NO_THROW(folder.CheckOwned("read-only.db"));
  WriteText(folder.path() / "open.db", "x");
  chmod((folder.path() / "open.db").c_str(), 0666);
  const std::string why = Message([&] { folder.CheckOwned("open.db"); });
  EXPECT_NE(why.find("may be written by other accounts (mode 0666)"), std::string::npos) << why;
  EXPECT_THROW(folder.OpenToRead("absent.db"), OwnershipError);
}

// A folder other accounts may write (a work_dir made in /tmp by someone else, or left open)
// would let them plant the daemon's files first: refused, naming the mode and the fix.
TEST(OwnedFolder, AFolderOthersMayWriteIsRefusedNamingTheFix) {
  const fs::path open = test::TempPath("open");
  fs::create_directories(open);
  chmod(open.c_str(), 0777);
  const std::string why = Message([&] { OwnedFolder::Open(open, "slurm.work_dir", false); });
  EXPECT_NE(why.find("slurm.work_dir " + open.string() + " may be written by other accounts"),
            std::string::npos)
      << why;
  EXPECT_NE(why.find("mode 0777"), std::string::npos) << why;
  EXPECT_NE(why.find("chmod go-w " + open.string()), std::string::npos) << why;
  chmod(open.c_str(), 01777);  // as /tmp
  const std::string shared =
      Message([&] { OwnedFolder::Open(open, "the database folder", false); });
  EXPECT_NE(shared.find("is shared with other accounts"), std::string::npos) << shared;
  EXPECT_NE(shared.find("install -d -m 0700"), std::string::npos) << shared;
}

TEST(OwnedFolder, AFolderThatIsALinkIsRefused) {
  const OwnedFolder real = MakeFolder("real");
  const fs::path link = test::TempPath("link");
  fs::remove(link);
  fs::create_directory_symlink(real.path(), link);
  const std::string why = Message([&] { OwnedFolder::Open(link, "slurm.work_dir", true); });
  EXPECT_NE(why.find("is a symbolic link"), std::string::npos) << why;
  fs::create_directory_symlink(real.path(), real.path() / "inner");
  EXPECT_THROW(real.Folder("inner", false), OwnershipError);
}

// Run as root (as CI is), the test can make what another account would have made.
TEST(OwnedFolder, AnotherAccountsFolderOrFileIsRefused) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root to give a file to another account";
  const fs::path theirs = test::TempPath("theirs");
  fs::create_directories(theirs);
  chmod(theirs.c_str(), 0700);
  ASSERT_EQ(chown(theirs.c_str(), 65534, 65534), 0);
  const std::string why = Message([&] { OwnedFolder::Open(theirs, "slurm.work_dir", true); });
  EXPECT_NE(why.find("belongs to nobody (owner nobody, mode 0700), but this dembufd runs as root"),
            std::string::npos)
      << why;
  EXPECT_NE(why.find("sudo -u nobody dembufd"), std::string::npos) << why;
  EXPECT_NE(why.find("install -d -m 0700 -o root DIR) and point slurm.work_dir at it"),
            std::string::npos)
      << why;
  const OwnedFolder mine = MakeFolder("mine");
  WriteText(mine.path() / "summary.json", "{}");
  ASSERT_EQ(chown((mine.path() / "summary.json").c_str(), 65534, 65534), 0);
  const std::string file = Message([&] { mine.Read("summary.json", 100); });
  EXPECT_NE(file.find("belongs to another account"), std::string::npos) << file;
}

// A link in place of a file a node leaves (samples.bin pointing at the database) is not
// followed, and a fifo does not hang the daemon.
TEST(OwnedFolder, ALinkOrAFifoInPlaceOfAFileIsNotRead) {
  const OwnedFolder folder = MakeFolder("links");
  WriteText(folder.path() / "secret", "the database");
  fs::create_symlink(folder.path() / "secret", folder.path() / "samples.bin");
  EXPECT_NE(Message([&] { folder.ReadFrom("samples.bin", 0, 100); }).find("symbolic link"),
            std::string::npos);
  ASSERT_EQ(mkfifo((folder.path() / "summary.json").c_str(), 0600), 0);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_NE(Message([&] { folder.Read("summary.json", 100); }).find("not a regular file"),
            std::string::npos);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(60));
  EXPECT_FALSE(folder.Read("absent", 100));
  EXPECT_EQ(folder.ReadFrom("absent", 0, 100), "");
}

TEST(OwnedFolder, WritingReplacesALinkInsteadOfFollowingIt) {
  const OwnedFolder folder = MakeFolder("write");
  WriteText(folder.path() / "victim", "keep");
  fs::create_symlink(folder.path() / "victim", folder.path() / "scene.toml");
  folder.Write("scene.toml", "[bed]\n");
  EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(folder.path() / "scene.toml")));
  std::ifstream victim(folder.path() / "victim");
  std::string kept;
  victim >> kept;
  EXPECT_EQ(kept, "keep");
  EXPECT_THROW(folder.Write("../x", "y"), std::runtime_error);
  struct stat written {};
  ASSERT_EQ(stat((folder.path() / "scene.toml").c_str(), &written), 0);
  EXPECT_EQ(written.st_mode & 0777, 0600u);
}

TEST(OwnedFolder, AFollowerReadsWholeSamplesExactlyAsTheyCome) {
  const OwnedFolder folder = MakeFolder("samples");
  const fs::path path = folder.path() / "samples.bin";
  report::SampleStreamWriter writer(path, std::chrono::milliseconds(0));
  const ImpactSample a{0.1, 1.0 / 3.0, -2.5e-300, std::nan(""), 4.0, 5.0};
  const ImpactSample b{0.2, 7.0, 8.0, 9.0, 10.0, 11.0};
  writer.Write(a);
  std::vector<ImpactSample> read =
      report::UnpackSamples(folder.ReadFrom("samples.bin", 0, 1 << 20));
  ASSERT_EQ(read.size(), 1u);
  EXPECT_EQ(read[0].plate_force_N, a.plate_force_N);
  EXPECT_EQ(read[0].wall_force_z_N, a.wall_force_z_N);
  EXPECT_TRUE(std::isnan(read[0].projectile_z_m));
  writer.Write(b);
  writer.Close();
  read = report::UnpackSamples(folder.ReadFrom("samples.bin", report::kPackedSampleBytes, 1 << 20));
  ASSERT_EQ(read.size(), 1u);
  EXPECT_EQ(read[0].t_s, 0.2);
  // A sample half written is not read.
  fs::resize_file(path, report::kPackedSampleBytes * 2 - 3);
  EXPECT_EQ(report::UnpackSamples(folder.ReadFrom("samples.bin", 0, 1 << 20)).size(), 1u);
  EXPECT_EQ(folder.ReadTail("samples.bin", 5).size(), 5u);
}

// A cluster job's snapshots are read back: a link, a name not allowed, too many files or
// bytes are refused, not followed or read.
TEST(OwnedFolder, AResultFolderIsReadBackWithinItsBounds) {
  const OwnedFolder dir = MakeFolder("result-files");
  fs::create_directories(dir.path() / "snapshots" / "peak");
  WriteText(dir.path() / "snapshots" / "peak" / "a.csv", "12345");
  WriteText(dir.path() / "snapshots" / "peak" / "b.csv", "");
  auto files = dir.ReadTree({"snapshots"}, report::IsSafeResultPath, 100, 10);
  ASSERT_EQ(files.size(), 2u);
  EXPECT_EQ(files[0].first, "snapshots/peak/a.csv");
  EXPECT_EQ(files[0].second, "12345");
  EXPECT_TRUE(dir.ReadTree({"absent"}, report::IsSafeResultPath, 100, 10).empty());
  WriteText(dir.path() / "plate_force_bare.csv", "t_s\n");
  files = dir.ReadTree({"snapshots", "plate_force_bare.csv"}, report::IsSafeResultPath, 100, 10);
  ASSERT_EQ(files.size(), 3u);
  EXPECT_EQ(files[0].first, "plate_force_bare.csv");
  EXPECT_THROW(dir.ReadTree({"snapshots"}, report::IsSafeResultPath, 4, 10), std::runtime_error);
  EXPECT_THROW(dir.ReadTree({"snapshots"}, report::IsSafeResultPath, 100, 1), std::runtime_error);
  fs::create_symlink("/etc/passwd", dir.path() / "snapshots" / "peak" / "c.csv");
  EXPECT_THROW(dir.ReadTree({"snapshots"}, report::IsSafeResultPath, 1 << 20, 10),
               std::runtime_error);
  fs::remove(dir.path() / "snapshots" / "peak" / "c.csv");
  fs::create_directory_symlink("/etc", dir.path() / "snapshots" / "etc");
  EXPECT_THROW(dir.ReadTree({"snapshots"}, report::IsSafeResultPath, 1 << 20, 10),
               std::runtime_error);
  fs::remove(dir.path() / "snapshots" / "etc");
  WriteText(dir.path() / "snapshots" / "peak" / "x y.csv", "");
  EXPECT_THROW(dir.ReadTree({"snapshots"}, report::IsSafeResultPath, 1 << 20, 10),
               std::runtime_error);
}

}  // namespace
}  // namespace dembuf::server
