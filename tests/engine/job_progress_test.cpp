// One progress over a whole job (dembuf/study/run/job_progress.h): it grows once from 0 to 1
// through the bed stages and the impact, where each stage's own fraction started again at 0.
#include <gtest/gtest.h>

#include "dembuf/study/run/job_progress.h"
#include "dembuf/study/scene/presets.h"

namespace dembuf {
namespace {

TEST(WholeJobProgress, GrowsOnceThroughTheBedStagesAndTheImpact) {
  Scene scene = PresetScene("e2");
  scene.bed.thickness_m = 0.02;
  const ResourceEstimate estimate = EstimateResources(scene);
  WholeJobProgress whole(estimate);
  double last = 0.0;
  auto expect_growth = [&](double now) {
    EXPECT_GE(now, last);
    EXPECT_LE(now, 1.0);
    last = now;
  };
  // The source bed settling, then soft and stiff; then the cut, which restarts its own clock.
  for (const char* stage : {"settling (soft)", "settling (stiffness restored)"})
    for (double t : {0.0, 0.1, 0.3, 0.5}) expect_growth(whole.WhileBed({stage, t, 2.0, 1000}));
  const double after_source = last;
  EXPECT_GT(after_source, 0.3);  // the source bed is most of the work
  for (double t : {0.0, 0.05, 0.2})
    expect_growth(whole.WhileBed({"relaxing the cut bed (locally)", t, 2.0, 6000}));
  EXPECT_GT(last, after_source);
  const double before_impact = last;
  for (double t : {0.05, 0.052, 0.054, 0.056}) expect_growth(whole.WhileImpact({t, 0.056, 0}));
  EXPECT_GT(before_impact, 0.5);
  EXPECT_DOUBLE_EQ(last, 1.0);
}

TEST(WholeJobProgress, ACachedBedWeighsNothing) {
  Scene scene = PresetScene("e2");
  scene.bed.thickness_m = 0.02;
  const ResourceEstimate estimate = EstimateResources(scene);
  std::vector<std::string> all;
  for (const StageEstimate& stage : estimate.stages) all.push_back(stage.hash);
  WholeJobProgress whole(estimate, all);
  EXPECT_DOUBLE_EQ(whole.WhileImpact({0.05, 0.06, 0}), 0.0);
  EXPECT_NEAR(whole.WhileImpact({0.055, 0.06, 0}), 0.5, 1e-12);
  EXPECT_EQ(BedStageOf("relaxing the cut bed (locally)"), "cut");
  EXPECT_EQ(BedStageOf("changing friction"), "friction");
  EXPECT_EQ(BedStageOf("settling (soft)"), "source");
}

}  // namespace
}  // namespace dembuf
