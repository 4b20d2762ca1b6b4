// The CallPool (call_pool.h): users take turns, one user's heavy calls leave threads for the
// others, and one user's flood waits behind itself within its bound.
#include "doors/call_pool.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace dembuf::server {
namespace {

using namespace std::chrono_literals;

// A gate calls wait at until the test opens it.
class Gate {
 public:
  void Wait() {
    std::unique_lock lock(m_mutex);
    m_changed.wait(lock, [&] { return m_open; });
  }
  void Open() {
    {
      std::lock_guard lock(m_mutex);
      m_open = true;
    }
    m_changed.notify_all();
  }

 private:
  std::mutex m_mutex;
  std::condition_variable m_changed;
  bool m_open = false;
};

// Opens a gate when it goes out of scope: declared after a pool, so that a failed assertion
// does not leave the pool's destructor waiting on calls at a closed gate.
struct OpenAtEnd {
  Gate& gate;
  ~OpenAtEnd() { gate.Open(); }
};

// Waits (up to a minute: a liveness check, not a timing) for `done`.
bool Eventually(const std::function<bool()>& done) {
  const auto until = std::chrono::steady_clock::now() + 60s;
  while (!done()) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(1ms);
  }
  return true;
}

// alice's sweeps hold their calls long (a large sweep's admission); bob's one call is answered
// while they do, and alice never has more than her two running. Without the per-user cap her
// calls took all four threads and bob waited for hers to end.
TEST(CallPool, OneUsersHeavyCallsLeaveThreadsForTheOthers) {
  Gate gate;
  std::atomic<int> alice_running{0}, alice_most{0}, alice_done{0};
  std::atomic<bool> bob_answered{false};
  {
    CallPool pool(4, 2, 64);
    OpenAtEnd open_at_end{gate};
    for (int k = 0; k < 8; ++k)
      ASSERT_TRUE(pool.Queue("alice", [&] {
        const int now = ++alice_running;
        int most = alice_most.load();
        while (now > most && !alice_most.compare_exchange_weak(most, now)) {
        }
        gate.Wait();
        --alice_running;
        ++alice_done;
      }));
    ASSERT_TRUE(Eventually([&] { return alice_running.load() == 2; }));
    ASSERT_TRUE(pool.Queue("bob", [&] { bob_answered = true; }));
    EXPECT_TRUE(Eventually([&] { return bob_answered.load(); }));
    EXPECT_EQ(alice_done.load(), 0) << "bob was answered only after alice's calls";
  }  // the pool runs what waits before it ends
  EXPECT_EQ(alice_done.load(), 8);
  EXPECT_EQ(alice_most.load(), 2);
}

// Calls of users with calls waiting are taken in turn, not oldest first: bob's single call
// goes before alice's backlog.
TEST(CallPool, UsersTakeTurns) {
  Gate gate;
  std::mutex mutex;
  std::vector<std::string> order;
  {
    CallPool pool(1, 1, 64);
    OpenAtEnd open_at_end{gate};
    ASSERT_TRUE(pool.Queue("hold", [&] { gate.Wait(); }));
    for (int k = 0; k < 3; ++k)
      ASSERT_TRUE(pool.Queue("alice", [&] {
        std::lock_guard lock(mutex);
        order.push_back("alice");
      }));
    ASSERT_TRUE(pool.Queue("bob", [&] {
      std::lock_guard lock(mutex);
      order.push_back("bob");
    }));
  }
  ASSERT_EQ(order.size(), 4u);
  EXPECT_EQ(order[0], "alice");
  EXPECT_EQ(order[1], "bob");
}

// A user's flood waits behind itself within its bound: the call past it is refused, another
// user's is not.
TEST(CallPool, AUsersWaitingCallsAreBounded) {
  Gate gate;
  std::atomic<bool> started{false};
  std::atomic<int> ran{0};
  {
    CallPool pool(1, 1, 3);
    OpenAtEnd open_at_end{gate};
    ASSERT_TRUE(pool.Queue("alice", [&] {
      started = true;
      gate.Wait();
    }));
    ASSERT_TRUE(Eventually([&] { return started.load(); }));
    int accepted = 0;
    for (int k = 0; k < 10; ++k) accepted += pool.Queue("alice", [&] { ++ran; }) ? 1 : 0;
    EXPECT_EQ(accepted, 3);
    EXPECT_TRUE(pool.Queue("bob", [&] { ++ran; }));
  }
  EXPECT_EQ(ran.load(), 4);
}

}  // namespace
}  // namespace dembuf::server
