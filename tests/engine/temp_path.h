// Paths for the tests' scratch files.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

namespace dembuf::test {

/// The scratch paths handed out to the running test.
inline std::vector<std::string>& ScratchOfThisTest() {
  static std::vector<std::string> paths;
  return paths;
}

/// Removes a test's scratch files and folders when it passes, so that repeated runs do not
/// fill the temporary folder; a failed test's stay for a look.
class RemoveScratchOfPassedTests : public testing::EmptyTestEventListener {
  void OnTestEnd(const testing::TestInfo& info) override {
    if (info.result()->Passed()) {
      std::error_code ignored;
      for (const std::string& path : ScratchOfThisTest())
        std::filesystem::remove_all(path, ignored);
    }
    ScratchOfThisTest().clear();
  }
};

inline const bool kScratchRemoverInstalled = [] {
  testing::UnitTest::GetInstance()->listeners().Append(new RemoveScratchOfPassedTests);
  return true;
}();

/// A path in the temporary folder that belongs to the running test and process alone, so that
/// tests run at once (ctest --parallel, two checkouts on one machine) never share a file.
inline std::string TempPath(const std::string& name) {
  const testing::TestInfo* info = testing::UnitTest::GetInstance()->current_test_info();
  std::string file = std::string("dembuf-") + info->test_suite_name() + "." + info->name() + "." +
                     std::to_string(getpid()) + "-" + name;
  // Parameterised tests are named "Prefix/Suite.Test/param": their slashes would be folders.
  std::replace_if(
      file.begin(), file.end(),
      [](unsigned char c) { return !std::isalnum(c) && c != '.' && c != '-' && c != '_'; }, '_');
  ScratchOfThisTest().push_back(testing::TempDir() + file);
  return ScratchOfThisTest().back();
}

}  // namespace dembuf::test
