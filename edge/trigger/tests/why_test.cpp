// vc_why: the reason buffer every edge constructor fills.
#include <gtest/gtest.h>

#include <cstring>

#include "voxcap/why.h"

TEST(Why, FormatsOneLine) {
  char why[64] = "stale";
  vc_why(why, sizeof why, "camera %d: %s", 1, "busy");
  EXPECT_STREQ(why, "camera 1: busy");
}

TEST(Why, TruncatesAndTerminates) {
  char why[8];
  std::memset(why, 'x', sizeof why);
  vc_why(why, 6, "%s", "0123456789");
  EXPECT_STREQ(why, "01234");
  EXPECT_EQ(why[6], 'x');  // nothing written past why_len
}

TEST(Why, NoBufferIsANoOp) {
  vc_why(nullptr, 16, "%s", "ignored");
  char why[4] = "abc";
  vc_why(why, 0, "%s", "ignored");
  EXPECT_STREQ(why, "abc");
  vc_why_clear(nullptr, 0);
  vc_why_clear(why, sizeof why);
  EXPECT_STREQ(why, "");
}
