// Paths for the tests' scratch files.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <string>

namespace dembuf::test {

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
  return testing::TempDir() + file;
}

}  // namespace dembuf::test
