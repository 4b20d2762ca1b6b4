// The resource estimate: computed from the scene alone, its counts are what a run then does
// (the source bed's beads exactly) or bounds of it (steps, samples), and a limit it passes is
// refused naming the field to change.
#include <gtest/gtest.h>

#include <cmath>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/run/resource_estimate.h"
#include "dembuf/study/scene/bed_plan.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
#include "engine/small_bed.h"

namespace dembuf {
namespace {

TEST(ResourceEstimate, CountsTheBedsAndBoundsTheStepsAndSamplesOfARealRun) {
  Scene scene = test::SmallBedScene();
  scene.time.output_interval_s = 1e-5;
  const ResourceEstimate e = EstimateResources(scene);
  ASSERT_EQ(e.stages.size(), 2u);
  EXPECT_EQ(e.stages[0].stage, "source");
  EXPECT_EQ(e.stages[1].stage, "cut");
  EXPECT_EQ(e.stages[0].hash, BedSourceHash(scene));
  EXPECT_EQ(e.stages[1].hash, BedHash(scene));

  BedCache beds;
  std::int64_t samples = 0;
  RunControl control;
  control.beds = &beds;
  control.on_sample = [&](const ImpactSample&) { ++samples; };
  const ImpactSummary run = RunImpact(scene, control);
  // The source bed: exactly the beads inserted. The cut bed: an upper bound, counted at a
  // solid fraction of 0.64 (the cylinder's wall leaves this small bed looser).
  const PreparedBed source = beds.FindOrMake(e.stages[0].hash, "source", [] {
    ADD_FAILURE() << "the source bed was not cached";
    return PreparedBed{};
  });
  EXPECT_EQ(e.stages[0].beads, static_cast<double>(source.beads.size()));
  EXPECT_GE(e.impact_beads, static_cast<double>(run.beads));
  EXPECT_LT(e.impact_beads, 1.5 * static_cast<double>(run.beads));
  EXPECT_LE(source.settle_steps, e.stages[0].steps_max);
  EXPECT_DOUBLE_EQ(e.dt_s, run.dt_s);
  // The flight to the bed's mean surface; the run's ends at the bead under the projectile.
  EXPECT_NEAR(e.flight_time_s, run.free_flight_s, 0.15 * run.free_flight_s);
  // The impact's steps (this run's and the bare plate's for lambda) and its samples.
  EXPECT_LE(static_cast<double>(run.steps), e.impact_steps_max);
  EXPECT_LE(static_cast<double>(samples), e.samples_max);
  EXPECT_GT(e.memory_bytes_max, e.MaxBeads() * 100);
  // A cached bed costs nothing more.
  const std::vector<std::string> cached = {e.stages[0].hash, e.stages[1].hash};
  EXPECT_DOUBLE_EQ(e.StepsMax(cached), e.impact_steps_max);
  EXPECT_LT(e.PredictedSeconds(1, cached), e.PredictedSeconds(1));
}

// A bed of several species steps at its quickest species' pace, as the run does, and a bed of
// layers counts every layer's beads.
TEST(ResourceEstimate, TakesTheStepOfTheQuickestSpeciesAndEveryLayer) {
  Scene glass = test::SmallBedScene();
  Scene with_steel = glass;
  with_steel.layers[0].fraction2 = 0.3;  // steel shot: E = 200 GPa, rho = 7850
  const ResourceEstimate a = EstimateResources(glass), b = EstimateResources(with_steel);
  EXPECT_EQ(a.dt_s, BuildWorld(glass).params.dt_s);
  EXPECT_EQ(b.dt_s, BuildWorld(with_steel).params.dt_s);
  EXPECT_LT(b.dt_s, 0.3 * a.dt_s);
  EXPECT_GT(b.impact_steps_max, 3.0 * a.impact_steps_max);
  Scene layered = glass;
  layered.bed.thickness_m = 0.012;
  layered.layers[0] = {.thickness_m = 0.005, .fraction2 = 1.0};
  const ResourceEstimate c = EstimateResources(layered);
  ASSERT_EQ(c.stages.size(), 2u);
  EXPECT_EQ(c.stages[0].beads, PlanSourceBed(layered).beads);
  EXPECT_EQ(PlanSourceBed(layered).layers.size(), 2u);
  // Both layers' beads are in the source, and each is poured: it takes longer to settle.
  EXPECT_GT(c.stages[0].beads, PlanSourceBed(layered).layers[1].beads);
  EXPECT_GT(c.stages[0].typical_settle_s, a.stages[0].typical_settle_s);
  // Its steps are bounded by each settling's: each layer's, and the cut's relaxation of the
  // lower (no soft settling in the small scene: one settling a layer).
  ASSERT_EQ(SoftSettlingFactor(layered), 1.0);
  EXPECT_EQ(c.stages[0].steps_max, 3.0 * (std::ceil(layered.bed.max_settle_s / c.dt_s) + 200));
}

TEST(ResourceEstimate, ALongRunsSamplesAreBoundedByItsSteps) {
  // An interval far below the time step writes one sample a step, not one per interval.
  Scene scene;
  scene.time.output_interval_s = 1e-300;
  const ResourceEstimate e = EstimateResources(scene);
  EXPECT_LE(e.samples_max, e.impact_steps_max + 1);
  EXPECT_LT(e.output_bytes_max, 1e8);
}

// The ResourceError that CheckResources throws ("" when within the limits).
std::string Refusal(const Scene& scene, const ResourceLimits& limits, std::string* field) {
  try {
    CheckResources(EstimateResources(scene), limits, scene, "this server's");
  } catch (const ResourceError& e) {
    *field = e.field();
    return e.what();
  }
  return "";
}

TEST(ResourceEstimate, APassedLimitNamesTheFieldTheEstimateAndTheLimit) {
  std::string field;
  // Beads of 1 um: the source bed would hold 3e15 beads (it allocated until the machine ran
  // out of memory).
  Scene tiny;
  tiny.bed.thickness_m = 0.02;
  tiny.beads.diameter_min_m = tiny.beads.diameter_max_m = 1e-6;
  ResourceLimits limits;
  limits.beads = 1e6;
  std::string why = Refusal(tiny, limits, &field);
  EXPECT_EQ(field, "beads.diameter_min_m");
  EXPECT_NE(why.find("about 3.22e+15 beads; this server's limit is 1e+06 per run"),
            std::string::npos)
      << why;
  // No limit, no refusal.
  EXPECT_EQ(Refusal(tiny, {}, &field), "");

  // A fixed end of 1000 s on the bare plate: 6.4e8 steps.
  Scene long_run;
  long_run.time.end_s = 1000;
  limits = {};
  limits.steps = 1e8;
  why = Refusal(long_run, limits, &field);
  EXPECT_EQ(field, "time.end_s");
  EXPECT_NE(why.find("up to 6.38e+08 time steps"), std::string::npos) << why;

  // Samples: one every microsecond of that run.
  long_run.time.output_interval_s = 1e-6;
  limits = {};
  limits.samples = 1e6;
  why = Refusal(long_run, limits, &field);
  EXPECT_EQ(field, "time.output_interval_s");
  EXPECT_NE(why.find("force samples; this server's limit is 1e+06"), std::string::npos) << why;

  // Settling counts: the E2 bed's stages at most bed.max_settle_s each.
  Scene bed;
  bed.bed.thickness_m = 0.02;
  limits = {};
  limits.bead_steps = 1e10;
  why = Refusal(bed, limits, &field);
  EXPECT_EQ(field, "bed.thickness_m");
  EXPECT_NE(why.find("settling at most 3 s per stage"), std::string::npos) << why;
  limits = {};
  limits.memory_bytes = 1e6;
  EXPECT_NE(Refusal(bed, limits, &field).find("of memory; this server's limit is 1 MB"),
            std::string::npos);
}

}  // namespace
}  // namespace dembuf
