// vc_log: one level scale (the host's names), a threshold from the daemon's verbosity, one sink.
#include "log.h"

#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

namespace {

struct Capture {
  std::vector<std::pair<vc_log_level, std::string>> lines;
  static void sink(void* user, vc_log_level level, const char* msg) {
    static_cast<Capture*>(user)->lines.emplace_back(level, msg);
  }
  Capture() { vc_log_set_sink(sink, this); }
  ~Capture() {
    vc_log_set_sink(nullptr, nullptr);
    vc_log_set_level(VC_LOG_INFO);
  }
};

}  // namespace

TEST(Log, LevelNamesAreTheHosts) {
  EXPECT_STREQ(vc_log_level_name(VC_LOG_DEBUG), "debug");
  EXPECT_STREQ(vc_log_level_name(VC_LOG_INFO), "info");
  EXPECT_STREQ(vc_log_level_name(VC_LOG_WARN), "warning");
  EXPECT_STREQ(vc_log_level_name(VC_LOG_ERROR), "error");
  EXPECT_EQ(vc_log_level_name(static_cast<vc_log_level>(7)), nullptr);
}

TEST(Log, VerbosityMapsToAThreshold) {
  EXPECT_EQ(vc_log_level_from_verbosity(-1), VC_LOG_WARN);
  EXPECT_EQ(vc_log_level_from_verbosity(0), VC_LOG_WARN);
  EXPECT_EQ(vc_log_level_from_verbosity(1), VC_LOG_INFO);
  EXPECT_EQ(vc_log_level_from_verbosity(2), VC_LOG_DEBUG);
  EXPECT_EQ(vc_log_level_from_verbosity(9), VC_LOG_DEBUG);
}

TEST(Log, WritesOnlyAtOrAboveTheThreshold) {
  Capture cap;
  vc_log_set_level(vc_log_level_from_verbosity(0));
  vc_log(VC_LOG_DEBUG, "d");
  vc_log(VC_LOG_INFO, "i");
  vc_log(VC_LOG_WARN, "camera %d silent", 1);
  vc_log(VC_LOG_ERROR, "e");
  ASSERT_EQ(cap.lines.size(), 2u);
  EXPECT_EQ(cap.lines[0].first, VC_LOG_WARN);
  EXPECT_EQ(cap.lines[0].second, "camera 1 silent");
  EXPECT_EQ(cap.lines[1].first, VC_LOG_ERROR);
  vc_log_set_level(VC_LOG_DEBUG);
  EXPECT_TRUE(vc_log_enabled(VC_LOG_DEBUG));
  vc_log(VC_LOG_DEBUG, "d");
  EXPECT_EQ(cap.lines.size(), 3u);
}

TEST(Log, LongLinesAreTruncatedNotOverrun) {
  Capture cap;
  std::string big(5000, 'x');
  vc_log(VC_LOG_ERROR, "%s", big.c_str());
  ASSERT_EQ(cap.lines.size(), 1u);
  EXPECT_GT(cap.lines[0].second.size(), 100u);
  EXPECT_LT(cap.lines[0].second.size(), big.size());
}

TEST(Log, StderrLineLooksLikeTheHosts) {
  vc_log_set_level(VC_LOG_INFO);
  testing::internal::CaptureStderr();
  vc_log(VC_LOG_WARN, "host connection %s", "down");
  std::string out = testing::internal::GetCapturedStderr();
  // [YYYY-MM-DD HH:MM:SS.mmm] [warning] voxcap-edge: host connection down
  ASSERT_GE(out.size(), 26u);
  EXPECT_EQ(out[0], '[');
  EXPECT_EQ(out[24], ']');
  EXPECT_EQ(out.substr(25), " [warning] voxcap-edge: host connection down\n");
}
