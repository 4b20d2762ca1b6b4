// Bed preparation, the rest criterion, exact saving and loading, hashes, and the engine's
// determinism whatever the number of threads.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <sstream>
#include <thread>
#include <type_traits>
#include <variant>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/bed/relaxation_cadence.h"
#include "dembuf/study/files/bed_export.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/presets.h"
#include "dembuf/study/scene/scene_fields.h"

#include "engine/small_bed.h"
#include "engine/temp_path.h"

namespace dembuf {
namespace {

using test::SmallBedScene;

// One preparation shared by the tests of this file (settling is their longest part, minutes
// under the sanitizers): the cache holds its source bed, from which other cuts are quick.
BedCache& SmallBedCache() {
  static BedCache cache;
  return cache;
}
std::set<std::string> g_small_bed_stages;  // the stages its preparation reported
const PreparedBed& SmallBed() {
  static const PreparedBed bed = [] {
    BedRequest request;
    request.on_progress = [](const BedProgress& p) { g_small_bed_stages.insert(p.stage); };
    return GetBed(SmallBedScene(), SmallBedCache(), request);
  }();
  return bed;
}

// `bed` at rest (its kinetic energy per bead below the scene's tolerance, its weight carried
// by the plate and the wall within 1%), its packing within `c0_share` and its surface within
// 1% of `other`'s.
void ExpectRestLike(const PreparedBed& bed, const PreparedBed& other, const Scene& scene,
                    double c0_share = 0.01) {
  EXPECT_LT(bed.kinetic_ratio, scene.bed.settle_tolerance);
  EXPECT_NEAR((bed.plate_force_N + bed.wall_force_z_N) / bed.weight_N, 1.0, 0.01);
  EXPECT_NEAR(bed.solid_fraction / other.solid_fraction, 1.0, c0_share);
  EXPECT_NEAR(bed.surface_m / other.surface_m, 1.0, 0.01);
}

// `bed`, relaxed in another way (`scene`'s) than `other` (SmallBed's scene): the same source
// and cut (as many beads), another key, and ExpectRestLike; prints both.
void ExpectAnotherRelaxationOfTheCut(const char* name, const PreparedBed& bed,
                                     const char* other_name, const PreparedBed& other,
                                     const Scene& scene) {
  EXPECT_EQ(BedSourceHash(scene), BedSourceHash(SmallBedScene()));
  EXPECT_NE(bed.hash, other.hash);
  EXPECT_EQ(bed.beads.size(), other.beads.size());
  ExpectRestLike(bed, other, scene);
  std::printf("%s: %lld steps, C0 %.4f, surface %.5f m; %s: %lld steps, C0 %.4f, surface %.5f m\n",
              name, static_cast<long long>(bed.settle_steps), bed.solid_fraction, bed.surface_m,
              other_name, static_cast<long long>(other.settle_steps), other.solid_fraction,
              other.surface_m);
}

TEST(BedPreparation, EndsAtRestByTheStatedCriterion) {
  const PreparedBed& bed = SmallBed();
  const Scene scene = SmallBedScene();
  EXPECT_EQ(bed.stage, "cut");
  EXPECT_GT(bed.beads.size(), 100u);
  // Rest: mean kinetic energy per bead below the tolerance (in m g d of the mean bead)...
  EXPECT_LT(bed.kinetic_ratio, scene.bed.settle_tolerance);
  // ...and the plate plus the wall's friction support carry the weight within 1%.
  EXPECT_NEAR((bed.plate_force_N + bed.wall_force_z_N) / bed.weight_N, 1.0, 0.01);
  // The weight is the beads' own.
  double mass = 0.0;
  for (double m : bed.beads.mass) mass += m;
  EXPECT_NEAR(bed.weight_N, mass * 9.81, 1e-12 * bed.weight_N);
  // Thickness reached by the cut within half a bead; a random packing's C0.
  EXPECT_NEAR(bed.surface_m, scene.bed.thickness_m, 0.5 * scene.beads.diameter_max_m);
  EXPECT_GT(bed.solid_fraction, 0.40);
  EXPECT_LT(bed.solid_fraction, 0.66);
  // Nothing outside the container, nothing through the plate.
  for (std::size_t i = 0; i < bed.beads.size(); ++i) {
    const dem::Vec3& x = bed.beads.position[i];
    EXPECT_LE(std::hypot(x.x(), x.y()) + bed.beads.radius[i], 0.02 * 1.001);
    EXPECT_GE(x.z() - bed.beads.radius[i], -1e-4 * bed.beads.radius[i]);
  }
}

TEST(BedPreparation, SavingAndLoadingIsBitExact) {
  PreparedBed bed = SmallBed();
  bed.warnings = {"bed.import: one", "bed.import: two"};  // an imported bed's, kept with it
  const auto path = std::filesystem::path(test::TempPath("small.bed"));
  SaveBed(bed, path);
  const PreparedBed back = LoadBed(path);
  ASSERT_EQ(back.beads.size(), bed.beads.size());
  EXPECT_EQ(std::memcmp(back.beads.position.data(), bed.beads.position.data(),
                        bed.beads.size() * sizeof(dem::Vec3)),
            0);
  EXPECT_EQ(std::memcmp(back.beads.radius.data(), bed.beads.radius.data(),
                        bed.beads.size() * sizeof(double)),
            0);
  ASSERT_EQ(back.history.size(), bed.history.size());
  for (std::size_t k = 0; k < bed.history.size(); ++k) {
    EXPECT_EQ(back.history[k].bead, bed.history[k].bead);
    EXPECT_EQ(back.history[k].other, bed.history[k].other);
    EXPECT_EQ(back.history[k].shear, bed.history[k].shear);
  }
  EXPECT_EQ(back.hash, bed.hash);
  EXPECT_EQ(back.surface_m, bed.surface_m);
  EXPECT_EQ(back.solid_fraction, bed.solid_fraction);
  EXPECT_EQ(back.warnings, bed.warnings);
}

TEST(BedPreparation, DamagedFileIsRefused) {
  const auto path = std::filesystem::path(test::TempPath("damaged.bed"));
  SaveBed(SmallBed(), path);
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(-100, std::ios::end);
    f.put('\x55');
  }
  EXPECT_THROW(LoadBed(path), std::runtime_error);
}

TEST(BedPreparation, ContactOfABeadTheFileDoesNotHoldIsRefused) {
  // A file whose checksum is right but whose contact names a bead beyond its beads (or a body
  // that is no wall) is refused on loading: the simulation indexes its beads by these ids.
  for (const auto& [bead, other] : {std::pair<dem::BodyId, dem::BodyId>{1000000, dem::kPlate},
                                    {0, 1000000},
                                    {0, dem::kProjectile}}) {
    PreparedBed bed = SmallBed();
    bed.history.push_back({bead, other, dem::Vec3(1e-9, 0, 0)});
    const auto path = std::filesystem::path(test::TempPath("bad-contact.bed"));
    SaveBed(bed, path);
    try {
      LoadBed(path);
      ADD_FAILURE() << "contact " << bead << "-" << other << " was accepted";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("contact"), std::string::npos) << e.what();
    }
  }
}

// A bed pushed to a daemon is checked against the scene it comes with: the bed itself
// passes, and each way a foreign or tampered bed differs is named.
TEST(BedPreparation, APreparedBedIsCheckedAgainstItsScene) {
  const PreparedBed& bed = SmallBed();
  const Scene scene = SmallBedScene();
  EXPECT_NO_THROW(CheckPreparedBed(bed, scene));
  auto refusal = [&](PreparedBed changed, const Scene& against) {
    try {
      CheckPreparedBed(changed, against);
    } catch (const SceneError& e) {
      EXPECT_EQ(e.field(), "bed");
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  Scene other_seed = scene;
  other_seed.bed.seed = 2;
  EXPECT_NE(refusal(bed, other_seed).find("none of the scene's beds"), std::string::npos);
  PreparedBed moved = bed;
  moved.beads.position[3].x() += scene.cylinder.radius_m;
  EXPECT_NE(refusal(moved, scene).find("bead 4 at"), std::string::npos);
  PreparedBed heavy = bed;
  heavy.beads.mass[0] *= 4.0;
  EXPECT_NE(refusal(heavy, scene).find("bead 1 weighs"), std::string::npos);
  PreparedBed moving = bed;
  moving.beads.velocity[5] = dem::Vec3(0.0, 0.0, 0.1);
  EXPECT_NE(refusal(moving, scene).find("bead 6 moves"), std::string::npos);
  PreparedBed lower = bed;
  for (dem::Vec3& x : lower.beads.position) x.z() -= 1e-4;  // every bead into the plate
  EXPECT_NE(refusal(lower, scene).find("outside the container"), std::string::npos);
}

// The largest distance a bead of `bed` moves when the bed is imported back (as a text file)
// and relaxed again from its beads alone.
double LargestMoveOnImport(const PreparedBed& bed, const Scene& scene) {
  Scene imported = scene;
  imported.bed.import = "again.txt";
  imported.bed.import_bytes = std::make_shared<const std::string>(
      ExportBed(bed.beads, scene, BedFormat::kText, "the bed imported back"));
  BedCache cache;
  const PreparedBed again = GetBed(imported, cache);
  EXPECT_EQ(again.beads.size(), bed.beads.size());
  double largest = 0.0;
  for (std::size_t i = 0; i < std::min(bed.beads.size(), again.beads.size()); ++i)
    largest = std::max(largest, (again.beads.position[i] - bed.beads.position[i]).norm());
  return largest;
}

TEST(BedPreparation, EveryBeadOfAPreparedBedIsAtRest) {
  // Rest is judged on the whole bed: its kinetic energy, and its weight against the plate's
  // and the wall's forces. A way of stopping beads that let that check pass right after a
  // stop made beds whose beads were held out of their own balance: stepped on, they moved by
  // millimetres (a column quench tried on the cut beds and withdrawn, docs/accuracy-cost.md).
  // Each way of bringing a bed to rest (local settling with the beads stopped at their peaks,
  // the default; the draft's looser rest, reached by kinetic damping of the whole bed; the
  // reference's tighter one) leaves
  // every bead where a free relaxation keeps it, within 10 um (a settled bed's beads move by
  // micrometres, the withdrawn column quench's by millimetres).
  const double moved = LargestMoveOnImport(SmallBed(), SmallBedScene());
  EXPECT_LT(moved, 1e-5) << "the default";
  Scene draft = SmallBedScene();
  ApplyAccuracy(draft, "draft");
  BedCache draft_beds;  // (its own source: the shared cache holds the one source others count)
  const double moved_draft = LargestMoveOnImport(GetBed(draft, draft_beds), draft);
  EXPECT_LT(moved_draft, 1e-5) << "the draft";
  // The reference's, its cut relaxed at four times its own step (0.2 for its 0.05).
  Scene reference = SmallBedScene();
  ApplyAccuracy(reference, "reference");
  ASSERT_DOUBLE_EQ(CutRelaxationAlpha(reference), 4.0 * reference.time.alpha);
  BedCache reference_beds;
  const double moved_reference = LargestMoveOnImport(GetBed(reference, reference_beds), reference);
  EXPECT_LT(moved_reference, 1e-5) << "the reference";
  std::printf(
      "the largest move: %.2g m (the default), %.2g m (the draft), %.2g m (the reference)\n", moved,
      moved_draft, moved_reference);
}

// A bed file's bytes that came with a request give the bed the file itself gives.
TEST(BedPreparation, ImportBytesAreTheFilesBed) {
  const std::string path = test::TempPath("import-bytes.txt");
  {
    std::ofstream out(path);
    for (std::size_t i = 0; i < SmallBed().beads.size(); ++i) {
      const dem::Vec3& x = SmallBed().beads.position[i];
      char line[160];
      std::snprintf(line, sizeof line, "%.17g %.17g %.17g %.17g\n", x.x(), x.y(), x.z(),
                    SmallBed().beads.radius[i]);
      out << line;
    }
  }
  Scene from_file = SmallBedScene();
  from_file.bed.import = path;
  std::ifstream in(path);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  Scene from_bytes = SmallBedScene();
  from_bytes.bed.import = "sent.txt";  // a name only: no such file here
  from_bytes.bed.import_bytes = std::make_shared<const std::string>(bytes.str());
  EXPECT_NO_THROW(ValidateScene(from_bytes));
  EXPECT_EQ(BedHash(from_bytes), BedHash(from_file));
  BedCache cache;
  const PreparedBed a = GetBed(from_file, cache);
  BedCache other;
  const PreparedBed b = GetBed(from_bytes, other);
  ASSERT_EQ(a.beads.size(), b.beads.size());
  EXPECT_EQ(0, std::memcmp(a.beads.position.data(), b.beads.position.data(),
                           a.beads.size() * sizeof(dem::Vec3)));
  std::remove(path.c_str());
}

TEST(BedPreparation, CachedBedIsReusedNotSettledAgain) {
  const auto dir = std::filesystem::path(test::TempPath("bed-cache"));
  std::filesystem::remove_all(dir);
  BedCache first(dir);
  const PreparedBed a = GetBed(SmallBedScene(), first);
  EXPECT_EQ(first.prepared_counts().at("source"), 1);
  EXPECT_EQ(first.prepared_counts().at("cut"), 1);
  // Another thickness from the same source: only a cut.
  Scene thinner = SmallBedScene();
  thinner.bed.thickness_m = 0.008;
  GetBed(thinner, first);
  EXPECT_EQ(first.prepared_counts().at("source"), 1);
  EXPECT_EQ(first.prepared_counts().at("cut"), 2);
  // A new process (a new cache object on the same folder) prepares nothing.
  BedCache second(dir);
  const PreparedBed b = GetBed(SmallBedScene(), second);
  EXPECT_TRUE(second.prepared_counts().empty());
  EXPECT_EQ(std::memcmp(a.beads.position.data(), b.beads.position.data(),
                        a.beads.size() * sizeof(dem::Vec3)),
            0);
}

// The two cut conventions: "surface" puts the measured mean surface at H; "tops" keeps only
// beads whose tops are below H, so its surface comes out lower (here by a quarter radius).
TEST(BedPreparation, TheTwoCutsPutTheSurfaceAtHOrEveryTopBelowIt) {
  BedCache& cache = SmallBedCache();
  const Scene scene = SmallBedScene();
  const double H = scene.bed.thickness_m;
  const double r_mean = 0.25 * (scene.beads.diameter_min_m + scene.beads.diameter_max_m);
  const PreparedBed& surface = SmallBed();
  Scene tops_scene = scene;
  tops_scene.bed.cut = "tops";
  const PreparedBed tops = GetBed(tops_scene, cache);
  EXPECT_EQ(cache.prepared_counts().at("source"), 1);  // one settling for both
  EXPECT_NEAR(surface.surface_m, H, 0.2 * r_mean);     // the cut bed sinks a little as it relaxes
  double highest_top = 0.0;
  for (std::size_t i = 0; i < tops.beads.size(); ++i)
    highest_top = std::max(highest_top, tops.beads.position[i].z() + tops.beads.radius[i]);
  // Relaxing only lets beads sink; 1% of a radius covers the resting overlaps released.
  EXPECT_LE(highest_top, H + 0.01 * r_mean);
  EXPECT_LT(tops.surface_m, surface.surface_m - 0.1 * r_mean);
  EXPECT_GT(tops.surface_m, H - 2.0 * r_mean);
  EXPECT_LT(tops.beads.size(), surface.beads.size());
}

// The "surface" cut's surface is a step function of the cut height (a bead more or less), so
// the best a cut can do is the step nearest to H. Beds small enough for the steps to be
// coarse (about 20 cells, 150 beads) at random: the cut must find that step, or be within the
// cut's tolerance of H (1e-3 of a radius), on every one of them.
TEST(BedPreparation, TheSurfaceCutFindsTheHeightNearestToH) {
  const double R = 0.02, H = 0.01, r_min = 0.002, r_max = 0.0025;
  for (int seed = 1; seed <= 40; ++seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(-1.0, 1.0), share(0.0, 1.0);
    dem::ParticleState beads;
    while (beads.size() < 150) {
      const dem::Vec3 x(R * unit(rng), R * unit(rng), 2.0 * H * share(rng));
      if (x.x() * x.x() + x.y() * x.y() < R * R)
        beads.Add(x, r_min + (r_max - r_min) * share(rng), 2500.0);
    }
    // Every cut there is: the lowest k beads, for k = 0 .. n.
    std::vector<std::size_t> by_height(beads.size());
    for (std::size_t i = 0; i < by_height.size(); ++i) by_height[i] = i;
    std::sort(by_height.begin(), by_height.end(), [&](std::size_t a, std::size_t b) {
      return beads.position[a].z() < beads.position[b].z();
    });
    double best = H;  // k = 0: bare plate
    dem::ParticleState lowest;
    for (std::size_t i : by_height) {
      lowest.Add(beads.position[i], beads.radius[i], 1.0);
      best = std::min(best, std::abs(MeasureSurface(lowest, R) - H));
    }
    const std::vector<bool> keep = CutMask(beads, R, H, "surface");
    dem::ParticleState kept;
    for (std::size_t i = 0; i < beads.size(); ++i)
      if (keep[i]) kept.Add(beads.position[i], beads.radius[i], 1.0);
    const double miss = std::abs(MeasureSurface(kept, R) - H);
    EXPECT_LE(miss, std::max(best, 1e-3 * r_min) + 1e-12)
        << "seed " << seed << ": the cut's surface misses H by " << miss << " m; a cut at " << best
        << " m from it exists";
  }
}

TEST(BedPreparation, KineticDampingReachesTheSameRest) {
  // The draft accuracy relaxes a cut bed with kinetic damping. From the same source (at the
  // draft's tolerance), the bed meets the same rest criterion, and its packing stays within
  // 1% of the freely relaxed one; it can stop sooner, before the last beads creep into place.
  BedCache cache;
  Scene free_scene = SmallBedScene();
  free_scene.bed.settle_tolerance = 1e-4;
  Scene quenched = free_scene;
  quenched.bed.quench_cut_relaxation = true;
  const PreparedBed free = GetBed(free_scene, cache);
  const PreparedBed bed = GetBed(quenched, cache);
  EXPECT_EQ(cache.prepared_counts().at("source"), 1);  // the source is shared
  EXPECT_EQ(bed.stage, "cut");
  EXPECT_EQ(bed.beads.size(), free.beads.size());  // the same cut of the same source
  ExpectRestLike(bed, free, quenched);
  std::printf("quenched: %lld steps, free: %lld steps\n", static_cast<long long>(bed.settle_steps),
              static_cast<long long>(free.settle_steps));
}

TEST(BedPreparation, LocalSettlingReachesTheSameRest) {
  // Local settling (the default) steps only the neighbourhood of the last moving beads. It is
  // used (its progress is reported), the bed meets the whole-bed rest criterion, and its
  // packing stays close to the bed settled as a whole: the beads it stops do not creep into
  // place, which can leave the top layer a little looser, most in the thinnest beds (C0 lower
  // by 0.2% in this bed of two layers, where a bead is 0.8% of C0; by 0.25% at most in the
  // paper's beds, or 0.7% with the cut's beads stopped at their peaks: docs/accuracy-cost.md).
  // Local settling version 1, which stopped more beads, left this bed 1.9% looser and fails
  // here.
  const PreparedBed& bed = SmallBed();
  Scene whole_scene = SmallBedScene();
  whole_scene.bed.local_settling = false;
  const PreparedBed whole = GetBed(whole_scene, SmallBedCache());
  EXPECT_TRUE(g_small_bed_stages.count("settling (locally)")) << "the source was settled whole";
  EXPECT_EQ(bed.stage, "cut");
  EXPECT_NE(bed.hash, whole.hash);
  ExpectRestLike(bed, whole, whole_scene, 0.015);
  std::printf(
      "local: %lld steps, %.1f s, C0 %.4f, surface %.5f m; whole: %lld steps, %.1f s, "
      "C0 %.4f, surface %.5f m; stages:",
      static_cast<long long>(bed.settle_steps), bed.wall_time_s, bed.solid_fraction, bed.surface_m,
      static_cast<long long>(whole.settle_steps), whole.wall_time_s, whole.solid_fraction,
      whole.surface_m);
  for (const std::string& stage : g_small_bed_stages) std::printf(" [%s]", stage.c_str());
  std::printf("\n");
}

TEST(BedPreparation, StoppingTheCutBedsBeadsAtTheirPeaksReachesRestSooner) {
  // By default a cut bed's local settling stops each bead whose kinetic energy has passed a
  // maximum (bed.quench_cut_beads). From the same source, the bed meets the same rest
  // criterion in fewer steps than without it, with nearly the same packing: the beads the
  // cut's spring-back sets rocking are stopped in their pockets instead of tapping each other
  // denser (in the paper's beds C0 comes out 0.0007 to 0.0035 lower, closer to a bed poured
  // to its thickness: docs/accuracy-cost.md).
  const PreparedBed& bed = SmallBed();
  Scene free_scene = SmallBedScene();
  free_scene.bed.quench_cut_beads = false;
  const PreparedBed free = GetBed(free_scene, SmallBedCache());
  EXPECT_TRUE(g_small_bed_stages.count("relaxing the cut bed (locally)"))
      << "the cut bed was not settled locally";
  EXPECT_LT(bed.settle_steps, free.settle_steps);
  ExpectAnotherRelaxationOfTheCut("free", free, "stopped at their peaks", bed, free_scene);
}

// The simulated times at which the cut's relaxation of `scene` checked its whole bed for
// rest, up to the first that found its weight carried within 1% (after which local settling
// may begin): its progress reports, cut from the small bed's cached source in a cache of its
// own.
std::vector<double> CutRestCheckTimes(const Scene& scene) {
  BedCache cache;
  cache.FindOrMake(BedSourceHash(scene), "source", [&] {
    return SmallBedCache().FindOrMake(BedSourceHash(scene), "source", [] {
      ADD_FAILURE() << "the small bed's source is not in the cache";
      return PreparedBed{};
    });
  });
  std::vector<double> times;
  bool balanced = false;  // local settling may follow any check that finds the balance within 1%
  BedRequest request;
  request.on_progress = [&](const BedProgress& p) {
    if (balanced || p.stage != "relaxing the cut bed") return;
    times.push_back(p.t_s);
    balanced = p.balance_error < 0.01;
  };
  GetBed(scene, cache, request);
  return times;
}

TEST(BedPreparation, TheCutBedRelaxesWithFourTimesTheStepCheckedAsOftenInTime) {
  // The default (bed.cut_alpha = 0): four times time.alpha's step. The cut bed meets the same
  // rest criterion as with time.alpha's step, in fewer steps, nearly the same bed, with every
  // bead in its own balance (an unstable step would throw beads out or never come to rest).
  const PreparedBed& bed = SmallBed();
  const Scene scene = SmallBedScene();
  ASSERT_DOUBLE_EQ(CutRelaxationAlpha(scene), 4.0 * scene.time.alpha);
  Scene impact_step = scene;
  impact_step.bed.cut_alpha = scene.time.alpha;
  const PreparedBed shorter = GetBed(impact_step, SmallBedCache());
  EXPECT_LT(bed.settle_steps, shorter.settle_steps);
  // time.alpha's step is the way before the longer step, to the bit (its step count then).
  EXPECT_EQ(shorter.settle_steps, 15250);
  ExpectAnotherRelaxationOfTheCut("time.alpha's step", shorter, "four times longer", bed,
                                  impact_step);
  EXPECT_LT(LargestMoveOnImport(bed, scene), 1e-5);
  // Its rest is checked at the same simulated times, every 50 of its steps instead of 200:
  // each check is a chance for the bed's spring-back to end, and checks four times rarer in
  // time let it tap the top beads denser (0.08 mm lower at 8 cm, docs/accuracy-cost.md).
  const std::vector<double> checks = CutRestCheckTimes(scene);
  const std::vector<double> impact_step_checks = CutRestCheckTimes(impact_step);
  ASSERT_FALSE(checks.empty());
  ASSERT_FALSE(impact_step_checks.empty());
  for (std::size_t k = 0; k < std::min(checks.size(), impact_step_checks.size()); ++k)
    EXPECT_NEAR(checks[k], impact_step_checks[k], 1e-9 * impact_step_checks[k]) << "check " << k;
  // The old way's beds are its own: time.alpha's step is another key than the default's.
  EXPECT_NE(BedHash(impact_step), BedHash(scene));
  // The automatic factor stays within time.alpha and the longest step checked...
  Scene other = scene;
  other.time.alpha = 0.4;
  EXPECT_DOUBLE_EQ(CutRelaxationAlpha(other), kLongestCheckedCutAlpha);
  other.time.alpha = 0.9;
  EXPECT_DOUBLE_EQ(CutRelaxationAlpha(other), 0.9);
  // The field's help states the rule (its text cannot be composed: the table holds views).
  const std::string help(FindSceneField("bed.cut_alpha")->help);
  char rule[64];
  std::snprintf(rule, sizeof rule, "%g x time.alpha, at most %g", kAutoCutStepMultiple,
                kLongestCheckedCutAlpha);
  EXPECT_NE(help.find(rule), std::string::npos) << help;
  // ...and is time.alpha's with the draft's kinetic damping of the whole bed, whose rest check
  // passed beds relaxed at longer steps with beads out of balance (at 0.6, a bead of this bed
  // moved 1.4 mm when imported back: EveryBeadOfAPreparedBedIsAtRest); set, it is refused.
  Scene draft = scene;
  ApplyAccuracy(draft, "draft");
  ASSERT_TRUE(draft.bed.quench_cut_relaxation);
  EXPECT_DOUBLE_EQ(CutRelaxationAlpha(draft), draft.time.alpha);
  draft.bed.cut_alpha = draft.time.alpha;  // its own step, named: accepted
  EXPECT_NO_THROW(ValidateScene(draft));
  draft.bed.cut_alpha = 0.6;
  try {
    ValidateScene(draft);
    ADD_FAILURE() << "bed.cut_alpha = 0.6 with the draft's kinetic damping was accepted";
  } catch (const SceneError& e) {
    for (const char* part : {"bed.cut_alpha", "0.6", "time.alpha = 0.4"})
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
  Scene bare = draft;  // no bed, so no cut to relax: nothing to refuse
  bare.bed.thickness_m = 0.0;
  EXPECT_NO_THROW(ValidateScene(bare));
  // A step shorter than the impact's is refused (a tiny one would never end), naming the field.
  Scene tiny = SmallBedScene();
  tiny.bed.cut_alpha = 1e-300;
  try {
    ValidateScene(tiny);
    ADD_FAILURE() << "bed.cut_alpha = 1e-300 was accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("bed.cut_alpha"), std::string::npos) << e.what();
  }
}

TEST(Cadence, ARelaxationWithALongerStepLooksAsOftenInSimulatedTime) {
  const Cadence same = Cadence::ForStepScale(1.0);
  EXPECT_EQ(same.rest_check, 200);
  EXPECT_EQ(same.region_check, 50);
  EXPECT_EQ(same.stall, 20000);
  const Cadence four = Cadence::ForStepScale(4.0);  // the default cut: 12.5 rounds to 13
  EXPECT_EQ(four.rest_check, 50);
  EXPECT_EQ(four.region_check, 13);
  EXPECT_EQ(four.stall, 5005);
  for (const double scale : {1.01, 3.2, 4.999, 16.0, 100.0, 1e6}) {
    const Cadence c = Cadence::ForStepScale(scale);
    EXPECT_GE(c.region_check, 1) << scale;
    EXPECT_EQ(c.stall % c.region_check, 0) << scale;
    // Within half a step (or the one step a count cannot go below) of the scene's times.
    EXPECT_NEAR(static_cast<double>(c.rest_check), std::max(200.0 / scale, 1.0), 0.5) << scale;
    EXPECT_NEAR(static_cast<double>(c.stall),
                std::max(20000.0 / scale, static_cast<double>(c.region_check)),
                0.5 * static_cast<double>(c.region_check) + 0.5)
        << scale;
  }
}

TEST(BedPreparation, ABeadSpinningInPlaceDoesNotKeepLocalSettlingGoing) {
  // The golden tests' small scene, settled softly (the default): local settling's last region
  // was 23 free beads around one bead that spun at 26 rad/s about the axis through its two
  // contacts, undamped (no rolling or twisting resistance), its energy just above the
  // region's target. Before regions stalled, that region ran until bed.max_settle_s (3 s,
  // 170,000 steps) and the bed failed; now it stops within kStallSteps.
  Scene scene;
  scene.cylinder.radius_m = 0.045;
  scene.bed.source_thickness_m = 0.025;
  scene.bed.thickness_m = 0.018;
  ASSERT_EQ(SoftSettlingFactor(scene), 100.0);
  BedCache cache;
  const PreparedBed bed = GetBed(scene, cache);
  const PreparedBed source = cache.FindOrMake(BedSourceHash(scene), "source", [] {
    ADD_FAILURE() << "the source bed is not in the cache";
    return PreparedBed{};
  });
  EXPECT_LT(source.settle_time_s, 1.0);  // 0.69 s; bed.max_settle_s is 3 s
  EXPECT_LT(bed.kinetic_ratio, scene.bed.settle_tolerance);
  std::printf("source: %.3f s simulated, %lld steps, %.1f s; cut: C0 %.4f\n", source.settle_time_s,
              static_cast<long long>(source.settle_steps), source.wall_time_s, bed.solid_fraction);
}

// The deepest overlap between two beads or a bead and the plate, over the smaller radius.
double DeepestOverlapRatio(const dem::ParticleState& b) {
  double deepest = 0.0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    deepest = std::max(deepest, (b.radius[i] - b.position[i].z()) / b.radius[i]);
    for (std::size_t j = i + 1; j < b.size(); ++j) {
      const double gap = (b.position[i] - b.position[j]).norm() - b.radius[i] - b.radius[j];
      deepest = std::max(deepest, -gap / std::min(b.radius[i], b.radius[j]));
    }
  }
  return deepest;
}

// The median length of the tangential springs' stretch.
double MedianStretch(const std::vector<dem::ContactHistoryEntry>& history) {
  std::vector<double> lengths;
  for (const dem::ContactHistoryEntry& h : history) lengths.push_back(h.shear.norm());
  std::nth_element(lengths.begin(), lengths.begin() + lengths.size() / 2, lengths.end());
  return lengths.empty() ? 0.0 : lengths[lengths.size() / 2];
}

TEST(BedPreparation, SoftSettlingEndsWithTheTrueStiffness) {
  // Soft settling forms the source's packing with Young's modulus divided by 100 (a ten times
  // longer step), then restores it. The beds meet the same rest criterion, the cut's packing
  // stays close to the one settled at the true stiffness, and the source ends with the true
  // stiffness's overlaps (the soft ones are 100^(2/3) = 21.5 times deeper) and its springs
  // stretched about as far as the true stiffness's. (That holds even without the springs'
  // rescaling: springs beyond Coulomb's limit at the restoring slip back to it.)
  const PreparedBed& stiff = SmallBed();
  Scene scene = SmallBedScene();
  scene.bed.soft_settling = 0.0;  // the default: automatic, 100 for the paper's glass
  ASSERT_EQ(SoftSettlingFactor(scene), 100.0);
  std::set<std::string> stages;
  BedRequest request;
  request.on_progress = [&](const BedProgress& p) { stages.insert(p.stage); };
  BedCache cache;
  const PreparedBed bed = GetBed(scene, cache, request);
  EXPECT_NE(bed.hash, stiff.hash);
  for (const char* stage : {"settling (soft)", "settling (stiffness restored)"})
    EXPECT_TRUE(stages.count(stage)) << stage;
  EXPECT_FALSE(stages.count("relaxing the cut bed (soft)"));
  EXPECT_LT(bed.kinetic_ratio, scene.bed.settle_tolerance);
  EXPECT_NEAR((bed.plate_force_N + bed.wall_force_z_N) / bed.weight_N, 1.0, 0.01);
  // This bed is two layers deep, and a few beads decide its packing: a bead is 0.8% of its
  // C0, and two packings of it cut at the surface nearest to H differ by a few beads (with
  // its cut's beads stopped at their peaks, the default, C0 came out 2.7% higher than the
  // stiff source's, 3 beads, and the surface 0.3% lower). So C0 within four beads. (In the
  // paper's beds, over three seeds, C0 within 0.003 and the surfaces within 0.1 mm:
  // docs/accuracy-cost.md.)
  EXPECT_NEAR(bed.solid_fraction / stiff.solid_fraction, 1.0, 4.0 / stiff.beads.size());
  EXPECT_NEAR(bed.surface_m / stiff.surface_m, 1.0, 0.02);
  // The source beds, which the cuts start from.
  const PreparedBed source = cache.FindOrMake(BedSourceHash(scene), "source", [] {
    ADD_FAILURE() << "the soft source bed is not in the cache";
    return PreparedBed{};
  });
  const PreparedBed source_stiff =
      SmallBedCache().FindOrMake(BedSourceHash(SmallBedScene()), "source", [] {
        ADD_FAILURE() << "the stiff source bed is not in the cache";
        return PreparedBed{};
      });
  const double deepest = DeepestOverlapRatio(source.beads);
  const double deepest_stiff = DeepestOverlapRatio(source_stiff.beads);
  EXPECT_LT(deepest, 2.0 * deepest_stiff);
  const double stretch = MedianStretch(source.history);
  const double stretch_stiff = MedianStretch(source_stiff.history);
  EXPECT_LT(stretch, 3.0 * stretch_stiff);
  EXPECT_GT(stretch, stretch_stiff / 3.0);
  std::printf(
      "soft: %lld steps, %.1f s, C0 %.4f, surface %.5f m, deepest overlap %.2e r, median "
      "stretch %.2e m; stiff: %lld steps, %.1f s, C0 %.4f, surface %.5f m, deepest overlap "
      "%.2e r, median stretch %.2e m\n",
      static_cast<long long>(bed.settle_steps), bed.wall_time_s, bed.solid_fraction, bed.surface_m,
      deepest, stretch, static_cast<long long>(stiff.settle_steps), stiff.wall_time_s,
      stiff.solid_fraction, stiff.surface_m, deepest_stiff, stretch_stiff);
}

TEST(BedPreparation, TheAutomaticSofteningKeepsThePourWithinItsOverlapLimit) {
  // Hertz's largest overlap goes as E^(-2/5): the automatic factor is the largest whole
  // number up to 100 with an overlap within 10% of the smallest bead's radius.
  Scene glass = SmallBedScene();
  glass.bed.soft_settling = 0.0;
  const double glass_overlap = SoftPourOverlap(glass, 1.0);
  EXPECT_NEAR(SoftPourOverlap(glass, 100.0) / glass_overlap, std::pow(100.0, 0.4), 1e-9);
  EXPECT_NEAR(SoftPourOverlap(glass, 100.0), 0.089, 0.001);  // the paper's glass, on the plate
  EXPECT_EQ(SoftSettlingFactor(glass), 100.0);
  // Ten times softer beads and walls: (0.1 / overlap)^(5/2) = 133 / 10 = 13.3 -> 13.
  Scene soft = glass;
  soft.material.youngs_modulus_Pa /= 10.0;
  soft.walls.youngs_modulus_Pa /= 10.0;
  const double expected = std::floor(std::pow(kMaxSoftOverlap / SoftPourOverlap(soft, 1.0), 2.5));
  EXPECT_EQ(expected, 13.0);
  EXPECT_EQ(SoftSettlingFactor(soft), expected);
  EXPECT_LE(SoftPourOverlap(soft, SoftSettlingFactor(soft)), kMaxSoftOverlap);
  EXPECT_GT(SoftPourOverlap(soft, SoftSettlingFactor(soft) + 1.0), kMaxSoftOverlap);
  ValidateScene(soft);
  // A thousand times softer: 22% already at the true stiffness, so no softening.
  Scene rubber = glass;
  rubber.material.youngs_modulus_Pa /= 1000.0;
  rubber.walls.youngs_modulus_Pa /= 1000.0;
  EXPECT_EQ(SoftSettlingFactor(rubber), 1.0);
  // A factor given is used as given; no bed, or an imported one, settles nothing softly.
  Scene given = glass;
  given.bed.soft_settling = 30.0;
  EXPECT_EQ(SoftSettlingFactor(given), 30.0);
  Scene bare = glass;
  bare.bed.thickness_m = 0.0;
  EXPECT_EQ(SoftSettlingFactor(bare), 1.0);
}

TEST(Simulation, MemoryBytesCountsTheBeadsAndTheLists) {
  // What the benchmark's bytes per bead rest on: at least the beads' own nine arrays (152 B a
  // bead) and 40 B per pair-list entry, and it grows with the bed, not with the steps.
  Scene scene = SmallBedScene();
  scene.cylinder.radius_m = 0.1;
  const double r = 0.5 * scene.beads.diameter_min_m;
  auto lattice = [&](int side) {
    dem::ParticleState beads;
    for (int z = 0; z < 4; ++z)
      for (int y = 0; y < side; ++y)
        for (int x = 0; x < side; ++x)  // 1% overlaps along x: one contact per neighbour
          beads.Add(
              dem::Vec3((x - side / 2) * 1.98 * r, (y - side / 2) * 2.2 * r, (z + 1) * 2.2 * r), r,
              scene.material.density_kg_m3);
    return dem::Simulation(MakeContactSetup(scene, r).params, beads, std::nullopt);
  };
  dem::Simulation small = lattice(10), large = lattice(20);
  small.RefreshForces();
  large.RefreshForces();
  const std::size_t n = large.beads().size();
  const std::size_t pairs = static_cast<std::size_t>(4 * 20 * 19);  // the x neighbours
  EXPECT_GE(large.MemoryBytes(), n * 152 + pairs * 40);
  // Per bead added (a fixed part, the batches of the force pass, cancels): the beads' arrays
  // and list entries, and not much more.
  const double added_beads = static_cast<double>(n - small.beads().size());
  const double per_bead =
      (static_cast<double>(large.MemoryBytes()) - small.MemoryBytes()) / added_beads;
  EXPECT_GE(per_bead, 152.0 + 40.0 * (pairs - 4 * 10 * 9) / added_beads);
  EXPECT_LT(per_bead, 1000.0);
  const std::size_t before = large.MemoryBytes();
  for (int k = 0; k < 20; ++k) large.Step();
  EXPECT_LE(large.MemoryBytes(), before + before / 10);
}

TEST(Simulation, BeadOriginsFollowTheReorderAndRemovals) {
  // Large beds are reordered in memory at list builds; BeadOrigins maps each bead back to the
  // state the simulation was made with, also after beads are removed.
  Scene scene = SmallBedScene();
  scene.cylinder.radius_m = 0.1;
  const double r = 0.5 * scene.beads.diameter_min_m;
  dem::ParticleState
      given;  // a lattice of 1,440 beads, numbered from the top down, far from cell order
  for (int z = 9; z >= 0; --z)
    for (int y = 11; y >= 0; --y)
      for (int x = 11; x >= 0; --x)
        given.Add(dem::Vec3((x - 6) * 2.2 * r, (y - 6) * 2.2 * r, (z + 1) * 2.2 * r), r,
                  scene.material.density_kg_m3);
  dem::Simulation sim(MakeContactSetup(scene, r).params, given, std::nullopt);
  sim.RefreshForces();
  auto expect_origins = [&](const char* when) {
    const std::vector<std::uint32_t>& origin = sim.BeadOrigins();
    ASSERT_EQ(origin.size(), sim.beads().size()) << when;
    std::size_t moved = 0;
    for (std::size_t k = 0; k < origin.size(); ++k) {
      EXPECT_EQ(sim.beads().position[k], given.position[origin[k]]) << when;
      EXPECT_EQ(sim.beads().radius[k], given.radius[origin[k]]) << when;
      moved += origin[k] != k;
    }
    EXPECT_GT(moved, origin.size() / 2) << when;  // the reorder did happen
  };
  expect_origins("after the first list build");
  sim.RemoveBeads([](std::size_t i) { return i % 3 != 0; });
  sim.RefreshForces();
  expect_origins("after removing a third");
}

TEST(Simulation, StopBeadsStopsThoseBeadsAlone) {
  // Three beads falling apart, spinning: stopping the middle one zeroes its velocity and spin
  // and nothing else; it then falls again from rest, under gravity alone.
  Scene scene = SmallBedScene();
  const double r = 0.5 * scene.beads.diameter_min_m;
  dem::ParticleState beads;
  for (int k = 0; k < 3; ++k) {
    beads.Add(dem::Vec3((k - 1) * 4.0 * r, 0.0, 0.01), r, scene.material.density_kg_m3);
    beads.velocity.back() = dem::Vec3(0.1 * k, 0.0, -0.2);
    beads.angular_velocity.back() = dem::Vec3(0.0, 5.0, 0.0);
  }
  dem::Simulation sim(MakeContactSetup(scene, r).params, beads, std::nullopt);
  sim.Step();
  const dem::ParticleState before = sim.beads();
  sim.StopBeads({1});
  const dem::ParticleState& after = sim.beads();
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(after.position[i], before.position[i]) << i;
    if (i == 1) continue;
    EXPECT_EQ(after.velocity[i], before.velocity[i]) << i;
    EXPECT_EQ(after.angular_velocity[i], before.angular_velocity[i]) << i;
  }
  EXPECT_EQ(after.velocity[1], dem::Vec3::Zero());
  EXPECT_EQ(after.angular_velocity[1], dem::Vec3::Zero());
  sim.Step();
  const double dt = sim.params().dt_s, g = sim.params().gravity_m_s2;
  EXPECT_NEAR(sim.beads().velocity[1].z(), -g * dt, 1e-12);
  EXPECT_NEAR(sim.beads().velocity[1].x(), 0.0, 1e-15);
  EXPECT_NEAR(sim.beads().position[1].z(), before.position[1].z() - 0.5 * g * dt * dt, 1e-15);
}

TEST(Simulation, SavedHistoriesFollowTheReorder) {
  // A saved bed's springs (the constructor's history, or those kept by RemoveBeads) belong to
  // the beads as they were numbered then; the first list build of a large bed renumbers the
  // beads in cell order, and every spring must land on its own contact all the same.
  Scene scene = SmallBedScene();
  scene.cylinder.radius_m = 0.1;
  const double r = 0.5 * scene.beads.diameter_min_m;
  dem::ParticleState given;  // 1,440 beads numbered from the top down, rows touching along x
  for (int z = 9; z >= 0; --z)
    for (int y = 11; y >= 0; --y)
      for (int x = 11; x >= 0; --x)
        given.Add(dem::Vec3((x - 6) * 1.98 * r, (y - 6) * 2.2 * r, 0.99 * r + z * 2.2 * r), r,
                  scene.material.density_kg_m3);
  auto id = [](int x, int y, int z) {
    return static_cast<dem::BodyId>(((9 - z) * 12 + (11 - y)) * 12 + (11 - x));
  };
  // A spring along y (tangent to every contact here), small enough to stay under Coulomb's
  // bound, and different for every contact so that none can stand for another.
  std::vector<dem::ContactHistoryEntry> history;
  for (int z = 0; z < 10; ++z)
    for (int y = 0; y < 12; ++y)
      for (int x = 0; x < 12; ++x) {
        const double s = 1e-9 * (1 + (x + 12 * (y + 12 * z)) % 97);
        if (x < 11) history.push_back({id(x, y, z), id(x + 1, y, z), dem::Vec3(0, s, 0)});
        if (z == 0) history.push_back({id(x, y, z), dem::kPlate, dem::Vec3(0, 2 * s, 0)});
      }
  dem::Simulation sim(MakeContactSetup(scene, r).params, given, std::nullopt, history);
  sim.RefreshForces();  // builds the lists, renumbers the beads, and keeps the springs
  const std::vector<std::uint32_t>& origin = sim.BeadOrigins();
  std::size_t renumbered = 0;
  for (std::size_t k = 0; k < origin.size(); ++k) renumbered += origin[k] != k;
  ASSERT_GT(renumbered, origin.size() / 2);
  std::map<std::pair<dem::BodyId, dem::BodyId>, dem::Vec3> found;
  for (const dem::ContactHistoryEntry& h : sim.ExportHistory()) {
    const dem::BodyId a = origin[h.bead];
    const dem::BodyId b = dem::IsBead(h.other) ? origin[h.other] : h.other;
    found[{std::min(a, b), std::max(a, b)}] = a < b ? h.shear : dem::Vec3(-h.shear);
  }
  ASSERT_EQ(found.size(), history.size());
  for (const dem::ContactHistoryEntry& h : history) {
    const auto it = found.find({std::min(h.bead, h.other), std::max(h.bead, h.other)});
    ASSERT_NE(it, found.end()) << h.bead << "-" << h.other;
    const dem::Vec3 wanted = h.bead < h.other ? h.shear : dem::Vec3(-h.shear);
    EXPECT_NEAR((it->second - wanted).norm(), 0.0, 1e-6 * h.shear.norm())
        << h.bead << "-" << h.other;
  }
}

TEST(BedCacheThreads, ABedAskedForByManyThreadsIsMadeOnce) {
  // Workers of a sweep or of the daemon ask for the same bed at once: one prepares it, the
  // others wait and get the same bed. A preparation that fails releases the waiters, and the
  // next caller tries again. (Also run under ThreadSanitizer: deploy/test.sh.)
  BedCache cache;
  auto three_beads = [](const std::string& hash) {
    PreparedBed bed;
    for (int i = 0; i < 3; ++i) bed.beads.Add(dem::Vec3(0.005 * i, 0, 0.00225), 0.00225, 2650.0);
    bed.hash = hash;
    bed.stage = "cut";
    return bed;
  };
  std::atomic<int> made{0};
  auto make = [&] {
    ++made;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));  // the others arrive meanwhile
    return three_beads("shared");
  };
  std::vector<std::size_t> sizes(4);
  {
    std::vector<std::jthread> workers;
    for (std::size_t t = 0; t < sizes.size(); ++t)
      workers.emplace_back(
          [&, t] { sizes[t] = cache.FindOrMake("shared", "cut", make).beads.size(); });
  }
  EXPECT_EQ(made.load(), 1);
  for (std::size_t n : sizes) EXPECT_EQ(n, 3u);
  EXPECT_EQ(cache.prepared_counts().at("cut"), 1);

  std::atomic<int> failures{0};
  auto fail_once = [&]() -> PreparedBed {
    if (failures++ == 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      throw std::runtime_error("the first preparation fails");
    }
    return three_beads("retried");
  };
  std::atomic<int> thrown{0}, got{0};
  {
    std::vector<std::jthread> workers;
    for (int t = 0; t < 3; ++t)
      workers.emplace_back([&] {
        try {
          cache.FindOrMake("retried", "cut", fail_once);
          ++got;
        } catch (const std::runtime_error&) {
          ++thrown;
        }
      });
  }
  EXPECT_EQ(thrown.load(), 1);  // only the thread whose preparation failed sees the failure
  EXPECT_EQ(got.load(), 2);     // one of the waiters prepared it again, the last found it
  EXPECT_EQ(failures.load(), 2);
}

TEST(BedCacheThreads, ARunWaitsOnlyForABedBeingPrepared) {
  // The rule parallel workers pick runs by: pass over a run whose source or bed another
  // running run is preparing, until that bed is ready.
  BedCache beds;
  const BedNeeds cut_a{"source-a", "cut-a1"};
  const BedNeeds other_cut_a{"source-a", "cut-a2"};
  const BedNeeds cut_b{"source-b", "cut-b1"};
  const BedNeeds bare_plate{"", ""};
  EXPECT_FALSE(WaitsForBed(cut_a, {}, beds));                   // nobody prepares anything
  EXPECT_TRUE(WaitsForBed(other_cut_a, {cut_a}, beds));         // its source is being settled
  EXPECT_TRUE(WaitsForBed(cut_a, {cut_a}, beds));               // its very bed is being made
  EXPECT_FALSE(WaitsForBed(cut_b, {cut_a}, beds));              // another source: go
  EXPECT_FALSE(WaitsForBed(bare_plate, {cut_a, cut_b}, beds));  // no bed at all: go
  auto bed = [](const std::string& hash) {
    PreparedBed b;
    b.hash = hash;
    b.stage = "source";
    return b;
  };
  beds.FindOrMake("source-a", "source", [&] { return bed("source-a"); });
  EXPECT_FALSE(WaitsForBed(other_cut_a, {cut_a}, beds));  // the source is ready: cut from it
  EXPECT_TRUE(WaitsForBed(cut_a, {cut_a}, beds));         // the cut itself is not yet
}

TEST(BedHash, IsStable) {
  // A fixed value: a change here means every cached bed is prepared again (raise
  // kBedPreparationVersion instead when that is intended).
  EXPECT_EQ(BedHash(SmallBedScene()), "7ce09db2fae30f3a");  // (since cut relaxation v2)
}

// `field` of `scene` set to another value it may take: a number 5% up (or down, or another in
// its range), the next seed, the other truth value or choice, another bed file's content, one
// more snapshot time.
Scene Changed(const Scene& scene, const SceneField& field) {
  Scene other = scene;
  std::visit(
      [&](auto ref) {
        auto& value = ref(other);
        using T = std::decay_t<decltype(value)>;
        if constexpr (std::is_same_v<T, double>) {
          for (const double candidate : {value * 1.05, value * 0.95, 0.0123, 0.5, 2.0})
            if (candidate != value && candidate <= field.max &&
                (field.min_open ? candidate > field.min : candidate >= field.min)) {
              value = candidate;
              return;
            }
          ADD_FAILURE() << field.name << ": no other value in range";
        } else if constexpr (std::is_same_v<T, std::int64_t>) {
          value += 1;
        } else if constexpr (std::is_same_v<T, bool>) {
          value = !value;
        } else if constexpr (std::is_same_v<T, std::string>) {
          if (field.name == "bed.import") {  // another file, by its content
            value = "other.txt";
            other.bed.import_bytes = std::make_shared<const std::string>("0 0 0.0012 0.0011\n");
          } else if (field.choices.empty()) {  // a name
            value += "x";
          } else {
            value = std::string(value == field.choices[0] ? field.choices[1] : field.choices[0]);
          }
        } else {
          value.push_back(0.01);
        }
      },
      field.ref);
  return other;
}

// The keys of every bed stage come from the field table's column: each field of the table,
// changed in turn, moves exactly the keys of the stages it shapes and of those after them. A
// new field says what it shapes (the column has no default), and this test holds it to it.
// (The scenes have every species and layer in use, so that every field acts in them.)
TEST(BedKeys, EveryFieldMovesTheKeysOfTheStagesItShapes) {
  using enum Shapes;
  Scene prepared = SmallBedScene();
  prepared.bed.source_thickness_m = 0.03;  // H 5% up or down is cut from the same source bed
  prepared.layers[0] = {.thickness_m = 0.004, .fraction2 = 0.3};
  prepared.layers[1] = {.thickness_m = 0.003, .fraction3 = 0.2};
  Scene imported = SmallBedScene();
  imported.bed.import = "bed.txt";
  imported.bed.import_bytes = std::make_shared<const std::string>("0 0 0.0011 0.0011\n");
  imported.bed.import_types = 3;
  const BedStageKeys prepared_keys = BedKeys(prepared), imported_keys = BedKeys(imported);
  // The prepared scene is of layers, so what shapes every cut shapes its source bed too (its
  // layers are cut between them); a bed of one layer's source it leaves alone.
  const Scene one_layer = SmallBedScene();
  const BedStageKeys one_layer_keys = BedKeys(one_layer);
  for (const SceneField& field : SceneFields()) {
    ASSERT_TRUE(!field.in_use || ((field.in_use(prepared) || field.shapes == kImportedBed) &&
                                  field.in_use(imported)))
        << field.name;
    const Shapes s = field.shapes;
    if (s != kImportedBed) {  // a bed file's fields shape only an imported bed
      const BedStageKeys keys = BedKeys(Changed(prepared, field));
      EXPECT_EQ(keys.source != prepared_keys.source, s == kSourceBed || s == kEveryCut)
          << field.name;
      EXPECT_EQ(keys.cut != prepared_keys.cut, s == kSourceBed || s == kEveryCut || s == kCutBed)
          << field.name;
      EXPECT_EQ(keys.friction != prepared_keys.friction,
                s == kSourceBed || s == kEveryCut || s == kCutBed || s == kFrictionBed)
          << field.name;
      if (s == kEveryCut) {
        EXPECT_EQ(BedKeys(Changed(one_layer, field)).source, one_layer_keys.source) << field.name;
      }
    }
    const BedStageKeys keys = BedKeys(Changed(imported, field));
    EXPECT_EQ(keys.import != imported_keys.import,
              s == kSourceBed || s == kFrictionBed || s == kImportedBed)
        << field.name;
  }
}

// A field that does not act in a scene (a species no layer mixes in) is left out of its keys:
// a bed of one species keeps the keys it had before there were species.
TEST(BedKeys, AFieldNotInUseMovesNoKey) {
  const Scene one = SmallBedScene();
  const BedStageKeys keys = BedKeys(one);
  int unused = 0;
  for (const SceneField& field : SceneFields()) {
    if (!field.in_use || field.in_use(one)) continue;
    ++unused;
    const Scene other = Changed(one, field);
    // A layer's thickness or fraction set makes a bed of layers or species: another bed (a bed
    // file's field shapes no prepared bed).
    if (field.in_use(other)) {
      if (field.shapes != Shapes::kImportedBed) {
        EXPECT_NE(BedKeys(other).source, keys.source) << field.name;
      }
      continue;
    }
    const BedStageKeys changed = BedKeys(other);
    EXPECT_EQ(changed.source, keys.source) << field.name;
    EXPECT_EQ(changed.cut, keys.cut) << field.name;
    EXPECT_EQ(changed.friction, keys.friction) << field.name;
  }
  EXPECT_GT(unused, 20);  // the species' and the layers' rows
  // Mixing species 2 in puts its rows in use, and moves the keys.
  Scene mixed = one;
  mixed.layers[0].fraction2 = 0.2;
  EXPECT_NE(BedKeys(mixed).source, keys.source);
  Scene denser = mixed;
  denser.species[0].density_kg_m3 *= 1.1;
  EXPECT_NE(BedKeys(denser).source, BedKeys(mixed).source);
}

TEST(BedKeys, AutomaticValuesAndBedFilesAreKeyedAsWhatTheyResolveTo) {
  // The automatic softening and the same factor given share their beds.
  Scene automatic = SmallBedScene(), given = SmallBedScene();
  automatic.bed.soft_settling = 0.0;
  given.bed.soft_settling = SoftSettlingFactor(automatic);
  ASSERT_GT(given.bed.soft_settling, 1.0);
  EXPECT_EQ(BedHash(automatic), BedHash(given));
  // A friction stage's tolerance of 0 means the settling's own.
  Scene zero = SmallBedScene(), same = SmallBedScene();
  zero.material.friction_bead_bead = same.material.friction_bead_bead = 0.2;
  zero.bed.friction_settle_tolerance = 0.0;
  same.bed.friction_settle_tolerance = same.bed.settle_tolerance;
  EXPECT_EQ(BedHash(zero), BedHash(same));
  // A bed file is named by its content, not by its name.
  Scene a = SmallBedScene(), b = SmallBedScene();
  a.bed.import = "a.txt";
  b.bed.import = "elsewhere/b.txt";
  a.bed.import_bytes = b.bed.import_bytes =
      std::make_shared<const std::string>("0 0 0.0011 0.0011\n");
  EXPECT_EQ(BedHash(a), BedHash(b));
  // Both cuts, and every friction after settling, share the source bed; the projectile and
  // the run's end shape no bed.
  Scene tops = SmallBedScene(), mu = SmallBedScene(), projectile = SmallBedScene();
  tops.bed.cut = "tops";
  mu.material.friction_bead_bead = 0.2;
  projectile.projectile.mass_kg = 0.2;
  projectile.time.end_s = 0.1;
  EXPECT_EQ(BedSourceHash(tops), BedSourceHash(SmallBedScene()));
  EXPECT_EQ(BedSourceHash(mu), BedSourceHash(SmallBedScene()));
  EXPECT_EQ(BedHash(projectile), BedHash(SmallBedScene()));
}

// 1500 beads (enough for the parallel blocks, >= 1024) in a 3 cm cylinder, thrown in random
// directions: they fall and collide with friction.
dem::ParticleState FallingBeads() {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  dem::ParticleState beads;
  for (int iz = 0; beads.size() < 1500; ++iz)
    for (int iy = -5; iy <= 5; ++iy)
      for (int ix = -5; ix <= 5; ++ix) {
        const double x = ix * 0.0048, y = iy * 0.0048;
        if (std::hypot(x, y) > 0.026) continue;
        beads.Add(dem::Vec3(x, y, 0.0025 + iz * 0.0048), 0.00225 + 0.0001 * u(rng), 2650.0);
        beads.velocity.back() = dem::Vec3(u(rng), u(rng), u(rng));
      }
  return beads;
}

bool SameBits(const std::vector<dem::Vec3>& a, const std::vector<dem::Vec3>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(dem::Vec3)) == 0;
}

TEST(Determinism, SameResultWhateverTheThreadCount) {
  Scene scene;
  scene.cylinder.radius_m = 0.03;
  World world = BuildWorld(scene);
  const dem::ParticleState beads = FallingBeads();
  // threads < 0: changed during the run (1, 2, 3, ...), as a sweep lending cores does.
  auto run = [&](int threads) {
    dem::WorldParams p = world.params;
    p.threads = std::max(threads, 1);
    dem::Simulation sim(p, beads, std::nullopt);
    long contacts = 0;
    for (int k = 0; k < 2000; ++k) {
      if (threads < 0 && k % 100 == 0) sim.SetThreads(1 + (k / 100) % 3);
      sim.Step();
      contacts += sim.observables().bead_contacts;
    }
    return std::make_pair(std::move(sim), contacts);
  };
  const auto [one, contacts] = run(1);
  for (int threads : {2, -1}) {
    const auto [other, unused] = run(threads);
    EXPECT_TRUE(SameBits(one.beads().position, other.beads().position)) << threads << " threads";
    EXPECT_EQ(one.observables().plate_force_N, other.observables().plate_force_N);
  }
  EXPECT_GT(contacts, 20'000);  // a colliding system: thousands of bead-bead collisions

  // Two workers of a local sweep, each running the simulation on two threads of its own: the
  // nested OpenMP teams of `dembuf sweep --jobs 2` when a worker is lent a core.
  std::vector<std::vector<dem::Vec3>> nested(2);
  const int levels = omp_get_max_active_levels();
  omp_set_max_active_levels(2);
#pragma omp parallel num_threads(2)
  nested[omp_get_thread_num()] = run(2).first.beads().position;
  omp_set_max_active_levels(levels);
  for (const std::vector<dem::Vec3>& positions : nested)
    EXPECT_TRUE(SameBits(one.beads().position, positions));
}

TEST(Determinism, DensePackingSameBitsWhateverTheThreadCount) {
  // Every bead of a packed block presses on six neighbours from the first step, so every sum
  // of forces has many terms and its order shows in the bits, at the edges between the
  // threads' shares too (the falling beads above mostly touch one or two at a time).
  Scene scene;
  scene.cylinder.radius_m = 0.05;
  const World world = BuildWorld(scene);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  dem::ParticleState beads;
  const double radius = 0.00225, spacing = 0.00445;  // overlaps of 1% of the diameter
  for (int iz = 0; iz < 11; ++iz)
    for (int iy = 0; iy < 12; ++iy)
      for (int ix = 0; ix < 12; ++ix) {
        beads.Add(dem::Vec3((ix - 5.5) * spacing, (iy - 5.5) * spacing, radius + iz * spacing),
                  radius, 2650.0);
        beads.velocity.back() = 0.1 * dem::Vec3(u(rng), u(rng), u(rng));
      }
  auto run = [&](int threads) {
    dem::WorldParams p = world.params;
    p.threads = threads;
    dem::Simulation sim(p, beads, std::nullopt);
    for (int k = 0; k < 300; ++k) sim.Step();
    return sim.beads().position;
  };
  const std::vector<dem::Vec3> one = run(1);
  for (int threads : {2, 3, 4}) EXPECT_TRUE(SameBits(one, run(threads))) << threads << " threads";
}

// A step leaves the beads' closing half kick pending (the next step does it in its first pass);
// whoever reads the beads completes it. Reading them between steps must change no bit, and
// what is read must be the state at time_s().
TEST(Determinism, LookingAtTheBeadsBetweenStepsChangesNothing) {
  Scene scene;
  scene.cylinder.radius_m = 0.03;
  const dem::WorldParams params = BuildWorld(scene).params;
  dem::Simulation unobserved(params, FallingBeads(), std::nullopt);
  dem::Simulation observed(params, FallingBeads(), std::nullopt);
  double kinetic = 0.0;
  for (int k = 0; k < 1000; ++k) {
    unobserved.Step();
    observed.Step();
    if (k % 3 == 0) kinetic += observed.beads().velocity[k].z();
    if (k % 7 == 0) kinetic += observed.BeadKineticEnergy();
    if (k == 500) kinetic += observed.Energy().Total() + observed.ExportHistory().size();
  }
  EXPECT_TRUE(std::isfinite(kinetic));
  EXPECT_TRUE(SameBits(observed.beads().velocity, unobserved.beads().velocity));
  EXPECT_TRUE(SameBits(observed.beads().angular_velocity, unobserved.beads().angular_velocity));
  EXPECT_TRUE(SameBits(observed.beads().position, unobserved.beads().position));

  // A bead in free fall, read after every step: v = -g t (velocity Verlet is exact for a
  // constant force, up to rounding).
  dem::ParticleState one;
  one.Add(dem::Vec3(0.0, 0.0, 0.05), 0.002, 2650.0);
  dem::Simulation falling(params, one, std::nullopt);
  for (int k = 0; k < 100; ++k) {
    falling.Step();
    const double t = falling.time_s();
    ASSERT_NEAR(falling.beads().velocity[0].z(), -params.gravity_m_s2 * t, 1e-12) << k;
    ASSERT_NEAR(falling.beads().position[0].z(), 0.05 - 0.5 * params.gravity_m_s2 * t * t, 1e-12)
        << k;
  }
}

TEST(SmallBedImpact, BuffersTheImpactEndToEnd) {
  // The whole pipeline on the small bed: the bed takes load off the plate.
  BedCache cache;
  RunControl control;
  control.beds = &cache;
  const ImpactSummary s = RunImpact(SmallBedScene(), control);
  EXPECT_GT(s.beads, 100u);
  EXPECT_GT(s.reference_peak_N, 0.0);
  EXPECT_LT(s.peaks.p_N, s.reference_peak_N);
  EXPECT_GT(s.lambda, 0.2);
  EXPECT_LT(s.lambda, 1.0);
  EXPECT_NEAR(s.lambda, (s.reference_peak_N - s.peaks.p_N) / s.reference_peak_N, 1e-12);
  EXPECT_GT(s.crater_depth_m, 0.0);  // the projectile entered the bed
  EXPECT_LT(s.crater_depth_m, s.bed.thickness_m + 0.006);
  EXPECT_GT(s.first_contact_time_s, 0.0);
  EXPECT_NEAR(s.bed.rest_plate_force_N + s.bed.rest_wall_force_z_N, s.bed.weight_N,
              0.01 * s.bed.weight_N);
  // The same scene again gives the same numbers (the run is deterministic).
  const ImpactSummary again = RunImpact(SmallBedScene(), control);
  EXPECT_EQ(again.peaks.p_N, s.peaks.p_N);
  EXPECT_EQ(again.crater_depth_m, s.crater_depth_m);
}

TEST(SmallBedImpact, SnapshotsAreTakenWhenAskedAndBalance) {
  BedCache cache;
  Scene scene = SmallBedScene();
  scene.output.snapshot_after_contact_s = {0.0002, 0.0005};
  scene.output.snapshot_times_s = {0.001};  // during the free flight: the bed at rest
  scene.output.snapshot_at_peak = true;
  std::vector<ImpactSnapshot> snaps;
  RunControl control;
  control.beds = &cache;
  control.on_snapshot = [&](const ImpactSnapshot& s) { snaps.push_back(s); };
  const ImpactSummary summary = RunImpact(scene, control);
  ASSERT_EQ(snaps.size(), 4u);
  const ImpactSnapshot* peak = nullptr;
  for (const auto& s : snaps) {
    if (s.label == "peak") peak = &s;
    EXPECT_EQ(s.positions.size(), summary.beads);
  }
  ASSERT_NE(peak, nullptr);
  EXPECT_NEAR(peak->t_s, summary.peak_plate_force_time_s, 1e-12);
  // The plate contacts of the peak snapshot carry the peak plate force. The snapshot takes the
  // damping term with full-step velocities, the step with half-step ones: 2% covers that.
  double plate = 0.0;
  for (const auto& c : peak->contacts)
    if (c.b == dem::kPlate) plate += c.normal_N;
  EXPECT_NEAR(plate / summary.peak_plate_force_N, 1.0, 0.02);
  // The flight-time snapshot shows the bed at rest: its plate load is the resting load, as
  // recorded before the residual jitter, below the rest tolerance, was zeroed. That jitter's
  // inertia and damping move the recorded load: by 0.02% with the cut relaxed at the
  // impact's step, 0.11% at four times it (the default); the rest check bounds it at 1%.
  const ImpactSnapshot& rest = snaps.front();
  EXPECT_EQ(rest.label, "t_1ms");
  EXPECT_TRUE(std::isnan(rest.t_after_contact_s));  // taken before the contact
  double rest_plate = 0.0;
  for (const auto& c : rest.contacts)
    if (c.b == dem::kPlate) rest_plate += c.normal_N;
  EXPECT_NEAR(rest_plate / summary.bed.rest_plate_force_N, 1.0, 2e-3);
  EXPECT_NEAR(snaps[1].t_s, summary.first_contact_time_s + 0.0002, 2 * summary.dt_s);
  // Snapshots after contact are named by that time, and know it.
  EXPECT_EQ(snaps[1].label, "after_contact_0.2ms");
  EXPECT_NEAR(snaps[1].t_after_contact_s, 0.0002, 2 * summary.dt_s);
}

}  // namespace
}  // namespace dembuf
