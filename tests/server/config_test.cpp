// The daemon's configuration: the example a lab installs (deploy/dembufd.toml) states the
// defaults of server/config.h, but for the three settings the service sets itself; a default
// changed in one place and not the other fails here.
#include "process/config.h"

#include <gtest/gtest.h>

namespace dembuf::server {
namespace {

TEST(ServerConfig, TheExampleFileStatesTheDefaults) {
  ServerConfig example;
  LoadConfigFile(DEMBUF_SOURCE_DIR "/deploy/dembufd.toml", example);
  ServerConfig defaults;
  // (Validation fills in what "auto" and 0 leave to the machine: alike for both.)
  ValidateConfig(example);
  ValidateConfig(defaults);
  // The service's own: its state folders (made by the unit) and a longer grace on stop.
  EXPECT_EQ(example.db, "/var/lib/dembuf/dembuf.db");
  EXPECT_EQ(example.log_file, "/var/log/dembuf/dembufd.log");
  EXPECT_EQ(example.shutdown_grace_s, 30);
  example.db = defaults.db;
  example.log_file = defaults.log_file;
  example.shutdown_grace_s = defaults.shutdown_grace_s;
  EXPECT_TRUE(example == defaults) << "deploy/dembufd.toml gives a value that is not the default";
}

// Each setting the example names is one the daemon knows (an unknown one is refused), and a
// changed default shows: the comparison is not vacuous.
TEST(ServerConfig, AChangedSettingIsSeenByTheComparison) {
  ServerConfig changed;
  LoadConfigText("quota_samples = 2e6\n", "test.toml", changed);
  EXPECT_FALSE(changed == ServerConfig{});
  EXPECT_THROW(LoadConfigText("quota_sample = 2e6\n", "test.toml", changed), ConfigError);
}

}  // namespace
}  // namespace dembuf::server
