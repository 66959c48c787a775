#include "sendq.h"

#include <gtest/gtest.h>

#include <vector>

namespace {

std::vector<uint8_t> msg(uint8_t tag, size_t len) {
  return std::vector<uint8_t>(len, tag);
}

vc_sendq* new_queue(unsigned max_msgs, size_t max_bytes) {
  vc_sendq* q = nullptr;
  char why[128] = "";
  EXPECT_EQ(vc_sendq_new(max_msgs, max_bytes, &q, why, sizeof why), 0) << why;
  EXPECT_STREQ(why, "");
  return q;
}

uint8_t peek_tag(vc_sendq* q) {
  const uint8_t* d = nullptr;
  size_t len = 0;
  EXPECT_EQ(vc_sendq_peek(q, &d, &len), 1);
  return d[0];
}

TEST(SendQueue, FifoOrder) {
  vc_sendq* q = new_queue(4, 1 << 20);
  for (uint8_t i = 1; i <= 3; i++) ASSERT_EQ(vc_sendq_push(q, msg(i, 10).data(), 10), 0);
  for (uint8_t i = 1; i <= 3; i++) {
    EXPECT_EQ(peek_tag(q), i);
    vc_sendq_pop(q);
  }
  const uint8_t* d;
  size_t len;
  EXPECT_EQ(vc_sendq_peek(q, &d, &len), 0);
  vc_sendq_free(q);
}

TEST(SendQueue, DropsOldestWhenFullByCount) {
  vc_sendq* q = new_queue(3, 1 << 20);
  for (uint8_t i = 1; i <= 5; i++) ASSERT_EQ(vc_sendq_push(q, msg(i, 10).data(), 10), 0);
  vc_sendq_stats st;
  vc_sendq_get_stats(q, &st);
  EXPECT_EQ(st.dropped, 2u);
  EXPECT_EQ(st.queued, 3u);
  EXPECT_EQ(peek_tag(q), 3);  // 1 and 2 were the oldest
  vc_sendq_free(q);
}

TEST(SendQueue, DropsOldestWhenFullByBytes) {
  vc_sendq* q = new_queue(100, 250);
  for (uint8_t i = 1; i <= 4; i++) ASSERT_EQ(vc_sendq_push(q, msg(i, 100).data(), 100), 0);
  vc_sendq_stats st;
  vc_sendq_get_stats(q, &st);
  EXPECT_EQ(st.queued, 2u);
  EXPECT_LE(st.queued_bytes, 250u);
  EXPECT_EQ(peek_tag(q), 3);
  vc_sendq_free(q);
}

TEST(SendQueue, NeverDropsTheMessageBeingSent) {
  vc_sendq* q = new_queue(2, 1 << 20);
  ASSERT_EQ(vc_sendq_push(q, msg(1, 10).data(), 10), 0);
  const uint8_t* sending = nullptr;
  size_t len = 0;
  ASSERT_EQ(vc_sendq_peek(q, &sending, &len), 1);
  for (uint8_t i = 2; i <= 6; i++) ASSERT_EQ(vc_sendq_push(q, msg(i, 10).data(), 10), 0);
  EXPECT_EQ(sending[0], 1);  // still intact while being written
  EXPECT_EQ(peek_tag(q), 1);
  vc_sendq_pop(q);
  EXPECT_EQ(peek_tag(q), 6);  // the newest survived
  vc_sendq_free(q);
}

TEST(SendQueue, OversizeMessageRejectedAndCounted) {
  vc_sendq* q = new_queue(4, 100);
  EXPECT_EQ(vc_sendq_push(q, msg(1, 101).data(), 101), -EMSGSIZE);
  vc_sendq_stats st;
  vc_sendq_get_stats(q, &st);
  EXPECT_EQ(st.dropped, 1u);
  EXPECT_EQ(st.queued, 0u);
  vc_sendq_free(q);
}

TEST(SendQueue, ClearCountsDrops) {
  vc_sendq* q = new_queue(8, 1 << 20);
  for (uint8_t i = 1; i <= 3; i++) vc_sendq_push(q, msg(i, 10).data(), 10);
  vc_sendq_clear(q);
  vc_sendq_stats st;
  vc_sendq_get_stats(q, &st);
  EXPECT_EQ(st.dropped, 3u);
  EXPECT_EQ(st.queued, 0u);
  EXPECT_EQ(vc_sendq_wait(q, 1), 0);
  vc_sendq_free(q);
}

TEST(SendQueue, PushIfRoomKeepsHalfTheQueueAndNeverDrops) {
  vc_sendq* q = new_queue(8, 100);
  for (uint8_t i = 1; i <= 3; i++) EXPECT_EQ(vc_sendq_push_if_room(q, msg(i, 10).data(), 10), 0);
  EXPECT_EQ(vc_sendq_push_if_room(q, msg(4, 30).data(), 30), -ENOBUFS);  // 60 bytes > half of 100
  EXPECT_EQ(vc_sendq_push_if_room(q, msg(4, 10).data(), 10), 0);         // 4 of 8 messages
  EXPECT_EQ(vc_sendq_push_if_room(q, msg(5, 1).data(), 1), -ENOBUFS);    // a 5th would pass half
  vc_sendq_stats st;
  vc_sendq_get_stats(q, &st);
  EXPECT_EQ(st.pushed, 4u);
  EXPECT_EQ(st.dropped, 0u);  // what did not fit is the caller's to count
  EXPECT_EQ(st.queued, 4u);
  // An ordinary push still takes the other half, then drops the oldest as before.
  for (uint8_t i = 5; i <= 9; i++) EXPECT_EQ(vc_sendq_push(q, msg(i, 10).data(), 10), 0);
  vc_sendq_get_stats(q, &st);
  EXPECT_EQ(st.queued, 8u);
  EXPECT_EQ(st.dropped, 1u);
  vc_sendq_free(q);
}

TEST(SendQueue, FreeNullIsNoop) {
  vc_sendq_free(nullptr);
}

TEST(SendQueue, BadLimitsSayWhy) {
  vc_sendq* q = reinterpret_cast<vc_sendq*>(0x1);
  char why[128];
  EXPECT_EQ(vc_sendq_new(0, 100, &q, why, sizeof why), -EINVAL);
  EXPECT_EQ(q, nullptr);
  EXPECT_STREQ(why, "send queue: max_msgs must be 1..4096");
  EXPECT_EQ(vc_sendq_new(4097, 100, &q, why, sizeof why), -EINVAL);
  EXPECT_EQ(vc_sendq_new(4, 0, &q, why, sizeof why), -EINVAL);
  EXPECT_STREQ(why, "send queue: max_bytes must be > 0");
  EXPECT_EQ(vc_sendq_new(4, 100, nullptr, nullptr, 0), -EINVAL);  // no reason buffer: still no crash
}

}  // namespace
