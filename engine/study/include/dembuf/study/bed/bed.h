// Bed preparation (docs/model.md section 4) and reuse.
//
// A bed is made in up to three stages, each a cached artifact named by a content hash of
// everything that determines it:
//   1. source: beads inserted at random (no overlaps) in a loose column, settled under gravity
//      with bead friction bed.prep_friction until at rest; thickness bed.source_thickness_m.
//   2. cut:    the source with every bead whose centre lies above a cut height removed (the cut
//      chosen so that the measured surface is at H), then relaxed to rest again.
//   3. friction: when mu_pp differs from prep_friction, mu_pp is ramped slowly from the one to
//      the other over bed.friction_ramp_s and the bed relaxed again (the paper's friction study).
// Rest means both: the mean kinetic energy per bead below bed.settle_tolerance * m g d (mean
// bead), and the plate plus the wall's vertical support equal to the bed's weight within 1%.
#pragma once

#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "dembuf/core/particles.h"
#include "dembuf/core/simulation.h"
#include "dembuf/study/scene/bed_plan.h"
#include "dembuf/study/scene/scene.h"

namespace dembuf {

/// Version of the preparation procedure; part of every bed hash. Raise it with any change
/// that alters the beds the procedure makes (insertion, settling, the integrator's sums), so
/// that stale cached beds are not reused. What each version changed: CHANGELOG.md.
inline constexpr int kBedPreparationVersion = 5;
/// Version of local settling (bed.local_settling), in the hash of the beds it makes. Raise it
/// with any change to how it settles (its thresholds among them).
inline constexpr int kLocalSettlingVersion = 3;
/// Version of soft settling (bed.soft_settling), in the hash of the beds it makes.
inline constexpr int kSoftSettlingVersion = 1;
/// Version of the bead-by-bead kinetic damping of the cut beds (bed.quench_cut_beads), in the
/// hash of the cut beds it makes.
inline constexpr int kCutBeadQuenchVersion = 1;
/// Version of how beds of several species or layers are made (mixing, pouring layers in turn,
/// their rest criterion), in the hash of those beds only.
inline constexpr int kSpeciesBedVersion = 1;
/// Version of the surface cut (bed.cut = "surface"), in the hash of the beds it cuts.
inline constexpr int kSurfaceCutVersion = 2;
/// Version of the cut beds' relaxation, in the hash of every cut bed. 2: a relaxation with a
/// longer step than time.alpha's checks its bed as often in simulated time, not in steps.
inline constexpr int kCutRelaxationVersion = 2;

/// A bed at rest, with what was measured on it.
struct PreparedBed {
  dem::ParticleState beads;
  std::vector<dem::ContactHistoryEntry> history;  ///< tangential springs, for an exact restart
  std::string hash;
  std::string stage;            ///< "source", "cut", "friction" or "import"
  double surface_m = 0.0;       ///< measured surface height (the bed thickness H)
  double solid_fraction = 0.0;  ///< C0 = bead volume / (pi R^2 H)
  double weight_N = 0.0;
  double plate_force_N = 0.0;   ///< at rest
  double wall_force_z_N = 0.0;  ///< vertical support by wall friction, at rest
  double kinetic_ratio = 0.0;   ///< rest criterion value reached
  double settle_time_s = 0.0;   ///< simulated time of this stage
  std::int64_t settle_steps = 0;
  double wall_time_s = 0.0;           ///< computing time of this stage
  double insert_time_s = 0.0;         ///< of which inserting the beads (a source bed)
  std::string note;                   ///< an imported bed's overlaps (ImportedBed::Describe)
  std::vector<std::string> warnings;  ///< where an imported file disagrees with the scene
};

struct BedProgress {
  std::string stage;
  double t_s = 0.0;
  double t_max_s = 0.0;
  std::size_t beads = 0;
  double kinetic_ratio = 0.0;  ///< current value of the rest criterion's kinetic part
  double balance_error = 0.0;  ///< |plate + wall - weight| / weight
};

/// Durable storage of prepared beds, by hash: a folder of bed files for the CLI, the database
/// for the daemon. Implementations need not be thread-safe: BedCache serialises the calls.
class BedStore {
 public:
  virtual ~BedStore() = default;
  /// The bed, or nothing when absent. Throws on a damaged bed.
  virtual std::optional<PreparedBed> Load(const std::string& hash) = 0;
  virtual void Save(const PreparedBed& bed) = 0;
  virtual bool Contains(const std::string& hash) = 0;
};

/// One file per bed, DIR/<hash>.bed, written atomically.
class FolderBedStore final : public BedStore {
 public:
  explicit FolderBedStore(std::filesystem::path dir);
  std::optional<PreparedBed> Load(const std::string& hash) override;
  void Save(const PreparedBed& bed) override;
  bool Contains(const std::string& hash) override {
    return std::filesystem::exists(m_dir / (hash + ".bed"));
  }

 private:
  std::filesystem::path m_dir;
};

/// Where prepared beds are found: the most recently used in memory, all of them in the store
/// (if any). Saving and loading is exact (the doubles' bits). Safe to share between threads:
/// while one thread prepares a bed, others asking for the same bed wait for it instead of
/// preparing it again.
class BedCache {
 public:
  /// A folder store in `dir`, or memory only (unbounded) when empty.
  explicit BedCache(std::filesystem::path dir = {});
  /// `beds_in_memory` bounds the memory a long-running process spends on beds.
  explicit BedCache(std::shared_ptr<BedStore> store, std::size_t beds_in_memory = 16);

  /// The bed of that hash: from memory, from the store, or made by `make` (once, whoever asks).
  PreparedBed FindOrMake(const std::string& hash, const std::string& stage,
                         const std::function<PreparedBed()>& make);

  /// Whether the bed is ready (in memory or in the store).
  bool Contains(const std::string& hash);

  /// Called (outside the cache's lock) after each bed this cache prepared is stored.
  void OnPrepared(std::function<void(const PreparedBed&)> callback);

  /// How many beds this cache prepared (not found) since it was made, per stage.
  std::map<std::string, int> prepared_counts() const;

 private:
  std::optional<PreparedBed> FindLocked(const std::string& hash);
  void RememberLocked(const PreparedBed& bed);

  std::shared_ptr<BedStore> m_store;
  std::size_t m_memory_limit;
  mutable std::mutex m_mutex;
  std::condition_variable m_done;
  std::map<std::string, PreparedBed> m_memory;
  std::list<std::string> m_memory_order;  ///< least recently stored first
  std::set<std::string> m_in_progress;
  std::map<std::string, int> m_prepared;
  std::function<void(const PreparedBed&)> m_on_prepared;
};

/// A bed as bytes (a text header, then the doubles' bits and a checksum) and back. ParseBed
/// throws std::runtime_error naming `name` on damaged or foreign bytes.
std::string SerializeBed(const PreparedBed& bed);
PreparedBed ParseBed(const std::string& bytes, const std::string& name);

/// The SHA-256 of a bed's contents: the data of its bytes (beads and springs, exact), not the
/// header (which holds how long it took to make).
std::string BedContentSha256(const PreparedBed& bed);

/// Writes / reads one bed file (binary, exact). Load throws std::runtime_error on a damaged
/// or foreign file.
void SaveBed(const PreparedBed& bed, const std::filesystem::path& path);
PreparedBed LoadBed(const std::filesystem::path& path);

struct BedRequest {
  const std::atomic<bool>* cancel = nullptr;
  std::function<void(const BedProgress&)> on_progress;
  /// When set: how many engine threads the preparation may use now, read between checks, so
  /// that a caller can lend it cores that would otherwise wait for this bed (0: the default).
  const std::atomic<int>* threads = nullptr;
};

/// The loose column a scene's source bed settles from: PlanSourceBed's beads at random
/// positions, without overlaps, from bed.seed (for a peer that settles it itself, as the
/// benchmark has LAMMPS do). Throws SceneError when they do not fit the cylinder.
dem::ParticleState InsertSourceBeads(const Scene& scene, const BedRequest& request = {});

/// The bed of a scene with bed.thickness_m > 0 or bed.import set: from the cache, or prepared
/// (and stored). Throws SceneError, SimulationError (a bed that will not settle) or Cancelled.
PreparedBed GetBed(const Scene& scene, BedCache& cache, const BedRequest& request = {});

/// Only the settled source bed a scene's bed is cut from: from the cache, or prepared (and
/// stored). A cluster prepares it once, in a job of its own, before the jobs that cut it.
/// Throws SceneError for a scene whose bed has no source (none, or imported).
PreparedBed GetSourceBed(const Scene& scene, BedCache& cache, const BedRequest& request = {});

/// The hash of the settled source bed a scene's bed is cut from ("" for none or an import):
/// scenes that share it share the expensive settling.
std::string BedSourceHash(const Scene& scene);

/// Checks a bed prepared elsewhere (pushed to a daemon) against the scene it is said to be
/// for: its hash and stage are one of the scene's bed stages, and its beads are what that
/// stage makes (the scene's sizes and density, inside the container, at rest, the surface and
/// weight it states, a cut bed's surface at H). The hash covers the procedure, not the
/// positions: this cannot tell a bed from one another build settled, only a bed from a
/// foreign or damaged one. Throws SceneError (field "bed") naming the first fault.
void CheckPreparedBed(const PreparedBed& bed, const Scene& scene);

/// The content hash of the bed a scene asks for (16 hex digits, FNV-1a 64 of a canonical text).
std::string BedHash(const Scene& scene);

/// The cache key of each stage a scene's bed may be made in. Each is the hash of the versions
/// of the procedures that make it and of every field the field table marks as shaping it or
/// a stage before it (SceneField::shapes; automatic values resolved, a bed file by its
/// content): a field cannot shape a bed and be left out of its key. An imported bed has only
/// `import`; a prepared one the other three (whether its friction stage runs or not).
struct BedStageKeys {
  std::string source, cut, friction, import;
};
BedStageKeys BedKeys(const Scene& scene);

/// The stages a scene's bed is made in, in order, with their hashes: source, cut (and
/// friction), or import; none without beads.
struct BedStage {
  std::string stage;
  std::string hash;
};
std::vector<BedStage> BedStagesOf(const Scene& scene);

/// The prepared beds a run needs: the settled source it is cut from and its own bed (each ""
/// for none). Runs that share them share the settling.
struct BedNeeds {
  std::string source_hash;
  std::string bed_hash;
};
BedNeeds BedNeedsOf(const Scene& scene);

/// Whether a run needing `needs` would only wait if it started now: one of the `running` runs
/// is preparing its source or its bed, and that bed is not ready in `beds` yet. Parallel
/// workers (the daemon's, a local sweep's) take another run meanwhile instead of waiting.
bool WaitsForBed(const BedNeeds& needs, const std::vector<BedNeeds>& running, BedCache& beds);

/// Surface height: the mean, over square cells of side 2 d_max covering the plate (cells whose
/// centre lies within R - d_max of the axis), of the highest bead top in the cell.
double MeasureSurface(const dem::ParticleState& beads, double cylinder_radius_m);

/// The beads a cut of a source bed keeps (true) for a bed of `thickness`: with convention
/// "surface" those whose centre lies below the height that puts the measured surface
/// (MeasureSurface) nearest to `thickness`, with "tops" those whose top is below it.
std::vector<bool> CutMask(const dem::ParticleState& beads, double cylinder_radius, double thickness,
                          const std::string& convention);

/// One layer of a bed of layers or species, as measured on the prepared bed.
struct LayerSummary {
  double bottom_m = 0.0;           ///< the measured top of the layers below (0: the plate)
  double top_m = 0.0;              ///< the measured surface of this layer's beads and those below
  double asked_top_m = 0.0;        ///< where the scene asked it to end (H for the top layer)
  double solid_fraction = 0.0;     ///< its beads' volume / (pi R^2 (top - bottom))
  std::vector<std::size_t> beads;  ///< its beads of each species (0-based)
};

/// The layers of a prepared bed of a scene (each bead's layer, dem::ParticleState::layer):
/// where each one's beads end (MeasureSurface of them and those below), its packing and its
/// beads of each species.
std::vector<LayerSummary> MeasureLayers(const dem::ParticleState& beads, const Scene& scene);

/// Bead volume / (pi R^2 H).
double SolidFraction(const dem::ParticleState& beads, double cylinder_radius_m, double thickness_m);

}  // namespace dembuf
