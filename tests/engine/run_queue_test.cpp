// The run queue a local sweep's workers and the daemon's share: order, the bed rule, the
// sharing of cores, and the ways a run leaves or re-enters the queue; and its pool of workers
// (QueueWorkers).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "dembuf/study/sweep/run_queue.h"

namespace dembuf::test {
namespace {

// A start callback that hands every run the same counter of threads.
auto Into(std::atomic<int>& threads) {
  return [&threads](RunQueue::Id) { return &threads; };
}

TEST(RunQueue, RunsGoInOrderAndAClosedQueueEndsWhenEmpty) {
  BedCache beds;
  RunQueue queue(beds, 2);
  queue.Push(1, {});
  queue.Push(2, {});
  queue.PushFront(3, {});
  queue.Close();
  std::atomic<int> threads{0};
  EXPECT_EQ(queue.Next(Into(threads)), 3);
  EXPECT_EQ(threads, 2);  // alone: both cores
  EXPECT_EQ(queue.Next(Into(threads)), 1);
  EXPECT_EQ(threads, 1);  // two running: one core each
  queue.Done(3);
  queue.Done(1);
  EXPECT_EQ(queue.Next(Into(threads)), 2);
  queue.Done(2);
  EXPECT_EQ(queue.Next(Into(threads)), std::nullopt);
}

// Owners take turns: one user's ten queued runs do not hold back another's one run longer
// than the run going now; runs of one owner keep their order.
TEST(RunQueue, OwnersTakeTurns) {
  BedCache beds;
  RunQueue queue(beds, 1);
  auto needs = [](const char* owner) { return RunQueue::Needs{{}, {}, owner}; };
  for (RunQueue::Id id = 1; id <= 10; ++id) queue.Push(id, needs("alice"));
  queue.Push(11, needs("bob"));
  queue.Push(12, needs("bob"));
  queue.Push(13, needs("carol"));
  queue.Close();
  std::atomic<int> threads{0};
  std::vector<RunQueue::Id> order;
  while (const std::optional<RunQueue::Id> id = queue.Next(Into(threads))) {
    order.push_back(*id);
    queue.Done(*id);
  }
  const std::vector<RunQueue::Id> turns = {1, 11, 13, 2, 12, 3, 4, 5, 6, 7, 8, 9, 10};
  EXPECT_EQ(order, turns);
}

// More workers than cores (dembuf sweep --jobs 8 on 2 cores): no more runs go at once than
// there are cores; the others start as runs end.
TEST(RunQueue, NoMoreRunsGoAtOnceThanThereAreCores) {
  BedCache beds;
  RunQueue queue(beds, 2);
  for (RunQueue::Id id = 1; id <= 4; ++id) queue.Push(id, {});
  queue.Close();
  std::atomic<int> a{0}, b{0};
  EXPECT_EQ(queue.Next(Into(a)), 1);
  EXPECT_EQ(queue.Next(Into(b)), 2);
  std::atomic<bool> started{false};
  std::jthread third([&] {
    std::atomic<int> threads{0};
    EXPECT_EQ(queue.Next(Into(threads)), 3);
    EXPECT_EQ(threads, 1);
    started = true;
    queue.Done(3);
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_FALSE(started) << "a third run started on two cores";
  EXPECT_EQ(queue.running(), 2u);
  queue.Done(1);
  third.join();
  EXPECT_TRUE(started);
  queue.Done(2);
  std::atomic<int> last{0};
  EXPECT_EQ(queue.Next(Into(last)), 4);
  EXPECT_EQ(last, 2);  // alone again: both cores
  queue.Done(4);
}

TEST(RunQueue, ARunWaitingForABedBeingPreparedIsPassedOver) {
  BedCache beds;  // empty: no bed is ready
  RunQueue queue(beds, 2);
  queue.Push(1, {{"source-a", "bed-a1"}, {}});
  queue.Push(2, {{"source-a", "bed-a2"}, {}});  // same source bed as run 1
  queue.Push(3, {{"source-b", "bed-b1"}, {}});
  queue.Close();
  std::atomic<int> first{0}, second{0};
  EXPECT_EQ(queue.Next(Into(first)), 1);
  // Run 2 would only wait for the source bed run 1 prepares: run 3 goes first.
  EXPECT_EQ(queue.Next(Into(second)), 3);
  queue.Done(3);
  EXPECT_EQ(first, 2);  // the worker preparing the bed gets the idle worker's core
  // Now every run left waits: Next blocks until run 1 ends.
  std::atomic<bool> started{false};
  std::jthread worker([&] {
    std::atomic<int> threads{0};
    EXPECT_EQ(queue.Next(Into(threads)), 2);
    started = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_FALSE(started);
  queue.Done(1);
  worker.join();
  EXPECT_TRUE(started);
}

// On 16 cores: the run preparing a source bed that others wait for keeps the cores its beds
// can feed while an independent run goes beside it; once the bed is ready, the cores follow
// what each run's own bed can feed.
TEST(RunQueue, ARunOthersWaitForGetsTheCoresItsBedsCanFeed) {
  BedCache beds;
  RunQueue queue(beds, 16);
  const RunLoad heavy{true, "source-a", 36805, 100, 8000, 10};
  queue.Push(1, {{"source-a", "bed-a1"}, heavy});
  queue.Push(2, {{"source-a", "bed-a2"}, heavy});
  queue.Push(3, {{"source-a", "bed-a3"}, heavy});
  queue.Push(4, {{"", ""}, {true, "", 0, 0, 0, 1}});  // a bare plate: one thread's work
  queue.Close();
  std::atomic<int> preparer{0}, bare{0};
  EXPECT_EQ(queue.Next(Into(preparer)), 1);
  EXPECT_EQ(preparer, 16);
  EXPECT_EQ(queue.Next(Into(bare)), 4);  // runs 2 and 3 wait for run 1's bed
  EXPECT_EQ(preparer, 15);
  EXPECT_EQ(bare, 1);
  // The source bed is ready: run 1 goes on to its 8,000-bead cut, which feeds 8 threads.
  PreparedBed source;
  source.hash = "source-a";
  beds.FindOrMake("source-a", "source", [&] { return source; });
  queue.Wake();
  EXPECT_EQ(preparer, 8);
  EXPECT_EQ(bare, 1);
  queue.Done(4);
  queue.Done(1);
}

TEST(RunQueue, RemovedRequeuedAndStopped) {
  BedCache beds;
  RunQueue queue(beds, 1);
  queue.Push(1, {{"s", "b"}, {}});
  queue.Push(2, {});
  const std::optional<RunQueue::Needs> removed = queue.Remove(1);
  ASSERT_TRUE(removed);
  EXPECT_EQ(removed->beds.bed_hash, "b");
  EXPECT_FALSE(queue.Remove(1));
  std::atomic<int> threads{0};
  EXPECT_EQ(queue.Next(Into(threads)), 2);
  EXPECT_FALSE(queue.Remove(2));  // running, not queued
  queue.Requeue(2);               // back at the front, no longer running
  EXPECT_EQ(queue.queued(), 1u);
  EXPECT_EQ(queue.running(), 0u);
  queue.Stop();
  EXPECT_EQ(queue.Next(Into(threads)), std::nullopt);  // stopped, although a run is queued
}

TEST(RunQueue, ACancelFlagEndsAWaitingWorker) {
  BedCache beds;
  std::atomic<bool> cancel{false};
  RunQueue queue(beds, 1, &cancel);  // never closed: Next would wait for more runs
  std::jthread worker([&] {
    std::atomic<int> threads{0};
    EXPECT_EQ(queue.Next(Into(threads)), std::nullopt);
  });
  cancel = true;  // as a signal handler sets it: no wake-up, the queue looks within a second
}

// The pool runs every run once, tells the queue of each end, and says a run has ended only
// once the queue no longer counts it (and so writes no more to its threads).
TEST(QueueWorkers, ARunEndsOnlyOnceTheQueueNoLongerCountsIt) {
  BedCache beds;
  RunQueue queue(beds, 1);
  for (RunQueue::Id id = 1; id <= 3; ++id) queue.Push(id, {});
  queue.Close();
  std::atomic<int> threads{0};
  std::vector<RunQueue::Id> ran;
  QueueWorkers::Work work;
  work.start = [&](RunQueue::Id, int) { return &threads; };
  work.run = [&](RunQueue::Id id, int worker, const std::atomic<int>* given) {
    EXPECT_EQ(worker, 0);
    EXPECT_EQ(given, &threads);
    EXPECT_EQ(queue.running(), 1u);
    ran.push_back(id);
    return QueueWorkers::RunEnd::kDone;
  };
  work.ended = [&](RunQueue::Id, int) { EXPECT_EQ(queue.running(), 0u); };
  QueueWorkers workers(queue, 1, std::move(work));
  workers.Join();
  EXPECT_EQ(ran, (std::vector<RunQueue::Id>{1, 2, 3}));
}

// What `start` hands out may go as the run ends: many workers, each run's counter freed in
// `ended`, while the others' starts and ends share the cores again (the sanitizer builds see a
// write to a counter already freed).
TEST(QueueWorkers, ARunsThreadCounterMayGoWhenItHasEnded) {
  BedCache beds;
  RunQueue queue(beds, 4);
  constexpr int kRuns = 2000;
  for (RunQueue::Id id = 0; id < kRuns; ++id) queue.Push(id, {});
  queue.Close();
  std::mutex mutex;
  std::map<RunQueue::Id, std::unique_ptr<std::atomic<int>>> counters;
  std::atomic<int> runs{0};
  QueueWorkers::Work work;
  work.start = [&](RunQueue::Id id, int) {
    std::lock_guard lock(mutex);
    return (counters[id] = std::make_unique<std::atomic<int>>(0)).get();
  };
  work.run = [&](RunQueue::Id, int, const std::atomic<int>* threads) {
    EXPECT_GE(threads->load(), 1);
    ++runs;
    return QueueWorkers::RunEnd::kDone;
  };
  work.ended = [&](RunQueue::Id id, int) {
    std::lock_guard lock(mutex);
    counters.erase(id);
  };
  QueueWorkers(queue, 4, std::move(work)).Join();
  EXPECT_EQ(runs, kRuns);
  EXPECT_TRUE(counters.empty());
  EXPECT_EQ(queue.running(), 0u);
}

// A run its worker puts back keeps its turn and is not told done: it runs again, and the queue
// ends empty.
TEST(QueueWorkers, ARequeuedRunRunsAgain) {
  BedCache beds;
  RunQueue queue(beds, 1);
  queue.Push(7, {});
  queue.Push(8, {});
  queue.Close();
  std::atomic<int> threads{0};
  std::vector<RunQueue::Id> ran;
  QueueWorkers::Work work;
  work.start = [&](RunQueue::Id, int) { return &threads; };
  work.run = [&](RunQueue::Id id, int, const std::atomic<int>*) {
    ran.push_back(id);
    if (id == 7 && ran.size() == 1) {
      queue.Requeue(id);
      return QueueWorkers::RunEnd::kRequeued;
    }
    return QueueWorkers::RunEnd::kDone;
  };
  QueueWorkers(queue, 1, std::move(work)).Join();
  EXPECT_EQ(ran, (std::vector<RunQueue::Id>{7, 7, 8}));
  EXPECT_EQ(queue.running(), 0u);
  EXPECT_EQ(queue.queued(), 0u);
}

}  // namespace
}  // namespace dembuf::test
