// Thread shares follow the measured speeds of the threads, within bounds, and always cover the
// whole pass.
#include "thread_shares.h"

#include <gtest/gtest.h>

namespace dembuf::dem::detail {
namespace {

TEST(ThreadShares, EqualUntilMeasured) {
  ThreadShares shares;
  shares.Prepare(4);
  for (int t = 0; t <= 4; ++t) EXPECT_DOUBLE_EQ(shares.Start(t, 4), t / 4.0);
  shares.Update(4);  // nothing recorded: no change
  EXPECT_DOUBLE_EQ(shares.Start(1, 4), 0.25);
}

TEST(ThreadShares, FollowTheMeasuredSpeeds) {
  // Thread 0 is twice as fast as thread 1: its share converges to 2/3.
  ThreadShares shares;
  shares.Prepare(2);
  for (int pass = 0; pass < 60; ++pass) {
    const double share0 = shares.Start(1, 2);
    shares.Record(0, 1000.0 * share0, share0 / 2.0);
    shares.Record(1, 1000.0 * (1.0 - share0), (1.0 - share0) / 1.0);
    shares.Update(2);
  }
  EXPECT_NEAR(shares.Start(1, 2), 2.0 / 3.0, 1e-3);
  EXPECT_EQ(shares.Start(0, 2), 0.0);
  EXPECT_EQ(shares.Start(2, 2), 1.0);  // exactly: the last share ends at the last bead
  // A team of another size starts again from equal shares.
  EXPECT_DOUBLE_EQ(shares.Start(1, 3), 1.0 / 3.0);
}

TEST(ThreadShares, NoShareVanishes) {
  // A thread that is almost stopped keeps about a fifth of an equal share (0.1 of two, less
  // the renormalisation: 0.097 in the steady state), so that it keeps measuring.
  ThreadShares shares;
  shares.Prepare(2);
  for (int pass = 0; pass < 100; ++pass) {
    shares.Record(0, 100.0, 1e-3);
    shares.Record(1, 100.0, 1e3);
    shares.Update(2);
  }
  const double slow_share = 1.0 - shares.Start(1, 2);
  EXPECT_GT(slow_share, 0.09);
  EXPECT_LE(slow_share, 0.1);
}

}  // namespace
}  // namespace dembuf::dem::detail
