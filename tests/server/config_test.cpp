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

// Every setting of the file can be given as a flag: the same table sets it, and the same errors
// name it.
TEST(ServerConfig, EverySettingIsAlsoAFlag) {
  ServerConfig config;
  ApplySettingFlag("quota_beads=2e6", config);
  ApplySettingFlag("max_watch_streams_per_user=3", config);
  ApplySettingFlag("slurm.partition=debug", config);  // text that is no TOML value is text
  ApplySettingFlag("slurm.extra_args=[\"--qos=low\"]", config);
  ApplySettingFlag("access=\"local\"", config);
  EXPECT_EQ(config.quota_beads, 2e6);
  EXPECT_EQ(config.max_watch_streams_per_user, 3);
  EXPECT_EQ(config.slurm.partition, "debug");
  EXPECT_EQ(config.slurm.extra_args, std::vector<std::string>{"--qos=low"});
  EXPECT_EQ(config.access, "local");
  auto message = [&](const std::string& flag) {
    try {
      ApplySettingFlag(flag, config);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message("quota_bead=5").find("unknown setting \"quota_bead\""), std::string::npos);
  EXPECT_NE(message("quota_beads=many").find("quota_beads has the wrong type"), std::string::npos);
  EXPECT_NE(message("quota_beads").find("KEY=VALUE"), std::string::npos);
  // A value cannot smuggle a second setting in.
  EXPECT_NE(message("quota_beads=5\nlisten=\"0.0.0.0:1\"").find("control character"),
            std::string::npos);
  EXPECT_EQ(message("slurm.partition=a = 1"), "accepted");
  EXPECT_EQ(config.slurm.partition, "a = 1");
}

// --check-config's text is a configuration file that reads back to the same settings.
TEST(ServerConfig, TheCheckedTextReadsBackToTheSameSettings) {
  ServerConfig config;
  LoadConfigText("quota_samples = 3e6\nworkers = 3\n[slurm]\npartition = \"p\"\n", "a.toml",
                 config);
  ServerConfig again;
  LoadConfigText(ConfigText(config), "printed", again);
  EXPECT_TRUE(again == config) << ConfigText(config);
}

}  // namespace
}  // namespace dembuf::server
