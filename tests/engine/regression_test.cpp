// Regression: the plate force F(t) of a small impact against a stored reference, so that speed
// work cannot change results unnoticed. The run is deterministic (bit-identical for any thread
// count on one build); the tolerance, 1e-9 of the peak force per sample, leaves room only for
// compilers that round differently. When a change is meant to alter results, regenerate with
//   DEMBUF_UPDATE_REFERENCE=1 build/tests/engine_tests --gtest_filter='Regression.*'
// and say why in the commit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "dembuf/study/impact/impact.h"
#include "engine/small_bed.h"

namespace dembuf {
namespace {

const char* const kReference = DEMBUF_TEST_DATA_DIR "/regression_small_impact.csv";

// The tests' small bed (its own seed), run for a fixed time: a few seconds to prepare and run.
// Settled bead by bead to the end, as when the reference was written.
Scene RegressionScene() {
  Scene s = test::SmallBedScene();
  s.bed.seed = 7;
  s.bed.local_settling = false;
  s.time.end_s = 0.02;
  s.time.output_interval_s = 2e-5;
  return s;
}

TEST(Regression, SmallImpactForceMatchesTheStoredReference) {
  std::vector<ImpactSample> samples;
  RunControl control;
  control.compute_reference = false;
  control.on_sample = [&](const ImpactSample& s) { samples.push_back(s); };
  RunImpact(RegressionScene(), control);
  ASSERT_GT(samples.size(), 100u);

  if (std::getenv("DEMBUF_UPDATE_REFERENCE")) {
    std::ofstream out(kReference);
    out << "t_s,plate_force_N\n";
    out.precision(17);
    for (const ImpactSample& s : samples) out << s.t_s << "," << s.plate_force_N << "\n";
    GTEST_SKIP() << "wrote " << kReference;
  }

  std::ifstream in(kReference);
  ASSERT_TRUE(in) << "no reference " << kReference;
  std::string line;
  std::getline(in, line);
  std::vector<std::pair<double, double>> reference;
  while (std::getline(in, line)) {
    std::istringstream row(line);
    double t = 0, f = 0;
    char comma = 0;
    row >> t >> comma >> f;
    reference.push_back({t, f});
  }
  ASSERT_EQ(samples.size(), reference.size());
  double peak = 0.0;
  for (const auto& [t, f] : reference) peak = std::max(peak, f);
  ASSERT_GT(peak, 10.0);  // the impact happened
  for (std::size_t k = 0; k < samples.size(); ++k) {
    ASSERT_NEAR(samples[k].t_s, reference[k].first, 1e-12) << "sample " << k;
    ASSERT_NEAR(samples[k].plate_force_N, reference[k].second, 1e-9 * peak)
        << "sample " << k << " at t = " << reference[k].first << " s";
  }
}

}  // namespace
}  // namespace dembuf
