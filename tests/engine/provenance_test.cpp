// Provenance: the SHA-256 is the standard one, a command line reads back in a shell into the
// same arguments, and a bed's content hash follows its beads, not how long it took to make.
#include "dembuf/study/files/provenance.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "dembuf/study/bed/bed.h"

namespace dembuf {
namespace {

TEST(Provenance, Sha256OfKnownTexts) {
  // FIPS 180-2, appendix B.1, and the empty string.
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(Sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
}

// The words bash makes of `line`, one per output line (none of the test's words holds a
// newline once read back, so a newline separates them).
std::vector<std::string> WordsBashReads(const std::string& line) {
  const std::string script = "for w in " + line + "; do printf '%s\\n' \"$w\"; done";
  std::string command = "bash -c '";
  for (char c : script) command += c == '\'' ? std::string("'\\''") : std::string(1, c);
  command += "'";
  std::vector<std::string> words;
  FILE* out = popen(command.c_str(), "r");
  if (!out) return words;
  std::array<char, 4096> buffer{};
  std::string text;
  while (std::fgets(buffer.data(), buffer.size(), out)) text += buffer.data();
  pclose(out);
  std::size_t start = 0;
  for (std::size_t end; (end = text.find('\n', start)) != std::string::npos; start = end + 1)
    words.push_back(text.substr(start, end - start));
  return words;
}

TEST(Provenance, CommandLineReadsBackInAShell) {
  const std::vector<std::string> args = {
      "dembuf",         "run",       "--set",       "time.end_s=0.1",    "--out", "it's a folder",
      "$HOME;rm -rf x", "tab\there", "caf\xc3\xa9", "back\\slash'quote", ""};
  std::vector<const char*> argv;
  for (const auto& a : args) argv.push_back(a.c_str());
  const std::string line = report::ShellCommandLine(static_cast<int>(argv.size()), argv.data());
  for (unsigned char c : line) EXPECT_TRUE(c >= 0x20 && c < 0x7f) << line;  // ASCII only
  EXPECT_EQ(line.substr(0, 38), "dembuf run --set time.end_s=0.1 --out ");
  EXPECT_EQ(WordsBashReads(line), args) << line;
}

TEST(Provenance, CommandLineKeepsNoToken) {
  const std::vector<std::string> args = {"dembuf",         "--token",  "s3cret", "submit",
                                         "--token=s3cret", "--tokens", "kept"};
  std::vector<const char*> argv;
  for (const auto& a : args) argv.push_back(a.c_str());
  const std::string line =
      report::ShellCommandLine(static_cast<int>(argv.size()), argv.data(), {"--token"});
  EXPECT_EQ(line.find("s3cret"), std::string::npos) << line;
  EXPECT_EQ(WordsBashReads(line),
            (std::vector<std::string>{"dembuf", "--token", "<hidden>", "submit", "--token=<hidden>",
                                      "--tokens", "kept"}));
  // What a server keeps of a line any client sent: the caller's token wherever it stands, and
  // the word after --token, bare or quoted.
  EXPECT_EQ(report::WithoutSecrets("py run.py --key abc123 --token 'x y' --token=z $'q\\x01' end",
                                   "abc123"),
            "py run.py --key <hidden> --token <hidden> --token=<hidden> $'q\\x01' end");
  EXPECT_EQ(report::WithoutSecrets("a --token", ""), "a --token");
  EXPECT_EQ(report::WithoutSecrets("a --token $'t\\x01k' b", ""), "a --token <hidden> b");
}

TEST(Provenance, BedHashFollowsTheBeadsNotTheTiming) {
  PreparedBed bed;
  bed.hash = "0123456789abcdef";
  bed.beads.Add({0.0, 0.0, 0.001}, 0.001, 2500.0);
  bed.beads.Add({0.01, 0.0, 0.002}, 0.001, 2500.0);
  bed.wall_time_s = 12.0;
  const std::string hash = BedContentSha256(bed);
  EXPECT_EQ(hash.size(), 64u);
  bed.wall_time_s = 99.0;  // made slower: the same bed
  EXPECT_EQ(BedContentSha256(bed), hash);
  bed.beads.position[1][2] = std::nextafter(0.002, 1.0);  // one bead moved by one ulp
  EXPECT_NE(BedContentSha256(bed), hash);
}

}  // namespace
}  // namespace dembuf
