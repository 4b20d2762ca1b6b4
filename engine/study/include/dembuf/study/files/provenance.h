// Where a result came from: the program that made it (version, commit, build type), what it
// ran (the scene's and the bed's SHA-256, the seed), where, when, on how many threads, and
// the command that asked for it. summary.json carries it as "provenance".
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "dembuf/study/impact/impact.h"
#include "dembuf/study/scene/scene.h"
#include "dembuf/study/text/sha256.h"

namespace dembuf::report {

/// Now, UTC, as ISO 8601 to the second ("2026-11-26T01:02:03Z").
std::string UtcNow();

/// This machine's host name ("" if it has none).
std::string HostName();

/// The arguments as one line a POSIX shell reads back into them (each quoted where needed).
std::string ShellCommandLine(int argc, const char* const* argv);

/// The same with the value of each option named in `secret_options` (such as "--token")
/// replaced by "<hidden>", written "--token VALUE" or "--token=VALUE": a command line is kept
/// with results and shown to whoever reads them, a secret must not be.
std::string ShellCommandLine(int argc, const char* const* argv,
                             const std::vector<std::string>& secret_options);

/// `line` with every occurrence of `secret` replaced by "<hidden>" (nothing for an empty one),
/// and the word after each "--token" or "--token=" too: what a server keeps of a command line
/// a client sent, whatever client it was.
std::string WithoutSecrets(std::string line, const std::string& secret);

/// The commit the program was built from ("unknown" outside a git checkout; "-dirty-" and 12
/// hex digits of a hash of the changes after it when the checkout had changes) and the build
/// type ("Release", ...).
const char* BuildCommit();
const char* BuildType();
/// The compiler, its version, the target processor and the compile flags ("GNU 12.2.0 x86_64
/// -O3 -march=x86-64-v2 ..."): with the commit and type, what a result's bits depend on.
const char* BuildConfig();
/// The C library the program runs with ("glibc 2.36"; "unknown" elsewhere): its libm rounds
/// pow, exp and the like, so a result's last bits depend on it too.
std::string LibcVersion();

/// What the caller knows of a run: the rest comes from the program, the scene and the bed.
struct RunContext {
  std::string command_line;  ///< what asked for it: the CLI's arguments, a client's request
  std::string host;
  std::string started_at;  ///< UTC, ISO 8601
  std::string finished_at;
  int threads = 0;
  /// What the run did, a line each, prefixed with its UTC time (RunJob writes it): its bed
  /// stages as they start and end, the impact's start and end. In log.txt.
  std::vector<std::string> timeline;
};

/// The paper whose model and experiments dembuf reproduces, as its provenance names it.
inline constexpr const char* kPaperReference =
    "Ji S., Fan L., Liang S., Buffer capacity of granular materials and its influencing factors "
    "based on discrete element method, Acta Physica Sinica 65, 104501 (2016), "
    "doi:10.7498/aps.65.104501";

/// A run starting now on this machine, asked for by `command_line`, on the engine's default
/// threads (OpenMP's, as OMP_NUM_THREADS sets them); finished_at is the caller's to set.
RunContext RunStartingNow(std::string command_line);

/// The canonical text of a scene, the resolved scene file (PrintScene): what its SHA-256 is
/// of, and what a run folder's scene.toml holds.
std::string SceneText(const Scene& scene);

/// How sure MadeByThisEngine must be that a result's bits are this program's.
enum class BuildMatch {
  /// The build's names are this program's: what a sweep resumed on its own machine compares.
  kSameNames,
  /// Also a build that names its commit and C library, whose flags name the target processor
  /// (not -march=native): what a daemon serving others' results to everyone requires.
  kIdentifiedBuild,
};

/// Whether a run's summary was written by this program's engine: the same version, commit
/// (with a hash of its changes), build type, compiler, flags and C library, so that its result
/// is the one this program would make; with kIdentifiedBuild, never for a build of unknown
/// commit or libc, or one whose flags leave the target to the building machine.
bool MadeByThisEngine(const nlohmann::json& summary, BuildMatch match);

/// Whether a run's summary says it ran the scene of canonical text `scene_text` (SceneText).
bool RanScene(const nlohmann::json& summary, const std::string& scene_text);

/// The "provenance" object of summary.json.
nlohmann::json ProvenanceJson(const RunContext& run, const Scene& scene, const BedSummary& bed);

}  // namespace dembuf::report
