// The bounded queue's three overflow policies and close().
#include "voxcap/pipeline/queue.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

namespace vc::pipeline {
namespace {

using namespace std::chrono_literals;

TEST(BoundedQueue, DropOldestKeepsTheNewestAndCountsTheEvicted) {
  BoundedQueue<int> q(3, Overflow::DropOldest);
  for (int i = 0; i < 5; i++) EXPECT_TRUE(q.push(i));
  QueueCounters c = q.counters();
  EXPECT_EQ(c.dropped, 2u);
  EXPECT_EQ(c.pushed, 5u);
  EXPECT_EQ(c.depth, 3u);
  EXPECT_EQ(c.max_depth, 3u);
  EXPECT_EQ(*q.pop(), 2);
  EXPECT_EQ(*q.pop(), 3);
  EXPECT_EQ(*q.pop(), 4);
}

TEST(BoundedQueue, DropNewestRefusesWithoutWaiting) {
  BoundedQueue<int> q(2, Overflow::DropNewest);
  EXPECT_TRUE(q.push(1));
  EXPECT_TRUE(q.push(2));
  auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(q.push(3));
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 100ms);
  EXPECT_EQ(q.counters().dropped, 1u);
  EXPECT_EQ(*q.pop(), 1);
  EXPECT_EQ(*q.pop(), 2);
  EXPECT_FALSE(q.pop_for(1ms).has_value());
}

TEST(BoundedQueue, BlockWaitsForRoomAndLosesNothing) {
  BoundedQueue<int> q(2, Overflow::Block);
  std::thread producer([&] {
    for (int i = 0; i < 100; i++) EXPECT_TRUE(q.push(i));
  });
  for (int i = 0; i < 100; i++) {
    std::optional<int> v = q.pop();
    ASSERT_TRUE(v.has_value());
    EXPECT_EQ(*v, i);
    if (i % 10 == 0) std::this_thread::sleep_for(1ms);  // a slow consumer now and then
  }
  producer.join();
  QueueCounters c = q.counters();
  EXPECT_EQ(c.dropped, 0u);
  EXPECT_GT(c.blocked, 0u);
  EXPECT_LE(c.max_depth, 2u);
}

TEST(BoundedQueue, CloseWakesABlockedProducerAndDrainsWhatIsLeft) {
  BoundedQueue<int> q(1, Overflow::Block);
  ASSERT_TRUE(q.push(1));
  std::atomic<int> result{-1};
  std::thread producer([&] { result = q.push(2) ? 1 : 0; });
  std::this_thread::sleep_for(50ms);
  EXPECT_EQ(result.load(), -1) << "the producer waits for room";
  q.close();
  producer.join();
  EXPECT_EQ(result.load(), 0) << "close() makes the waiting push fail";
  EXPECT_EQ(q.counters().refused_closed, 1u);
  EXPECT_EQ(*q.pop(), 1) << "what was queued is still delivered";
  EXPECT_FALSE(q.pop().has_value());
  EXPECT_TRUE(q.closed_and_empty());
  EXPECT_FALSE(q.push(3));
}

TEST(BoundedQueue, PushAlwaysKeepsOrderPastTheCapacityWithoutWaitingOrDropping) {
  BoundedQueue<int> q(2, Overflow::DropNewest);
  EXPECT_TRUE(q.push(1));
  EXPECT_TRUE(q.push(2));
  EXPECT_FALSE(q.push(3));
  EXPECT_TRUE(q.push_always(4));
  EXPECT_EQ(q.counters().depth, 3u);
  EXPECT_EQ(q.counters().dropped, 1u);
  EXPECT_EQ(*q.pop(), 1);
  EXPECT_EQ(*q.pop(), 2);
  EXPECT_EQ(*q.pop(), 4);
  q.close();
  EXPECT_FALSE(q.push_always(5));
}

TEST(BoundedQueue, ZeroCapacityIsRejected) {
  EXPECT_THROW(BoundedQueue<int>(0, Overflow::Block), std::invalid_argument);
}

}  // namespace
}  // namespace vc::pipeline
