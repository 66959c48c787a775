// The host's logger: the line format (the edge's, with the program's name), the threshold, the
// default logger after init(), and the Fn a component takes (its owner's, or spdlog).
#include "voxcap/base/log.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <sstream>
#include <utility>
#include <vector>

namespace vc::log {
namespace {

using ::testing::ElementsAre;
using ::testing::MatchesRegex;
using ::testing::Pair;

// Lines the named logger writes, captured beside its stderr sink.
struct Capture {
  explicit Capture(const std::string& program) : l(logger(program)) {
    l->sinks().push_back(std::make_shared<spdlog::sinks::ostream_sink_st>(out));
    l->set_pattern(kPattern);  // the new sink gets the logger's format too
  }
  ~Capture() { l->sinks().pop_back(); }
  std::shared_ptr<spdlog::logger> l;
  std::ostringstream out;
};

TEST(HostLog, TheLineReadsLikeTheEdges) {
  Capture c("log-test-line");
  to_spdlog("log-test-line")(Level::warn, "host connection down");
  // [YYYY-MM-DD HH:MM:SS.mmm] [warning] <program>: ..., as edge/daemon/tests/log_test.cpp expects
  // of voxcap-edge.
  EXPECT_THAT(c.out.str(),
              MatchesRegex("\\[[0-9]{4}-[0-9]{2}-[0-9]{2} [0-9]{2}:[0-9]{2}:[0-9]{2}\\.[0-9]{3}\\] "
                           "\\[warning\\] log-test-line: host connection down\n"));
  ASSERT_GE(c.out.str().size(), 25u);
  EXPECT_EQ(c.out.str().substr(25), " [warning] log-test-line: host connection down\n");
}

TEST(HostLog, OneLoggerPerProgram) {
  EXPECT_EQ(logger("log-test-same"), logger("log-test-same"));
  EXPECT_NE(logger("log-test-same"), logger("log-test-other"));
}

TEST(HostLog, BracesInALineAreText) {
  Capture c("log-test-braces");
  to_spdlog("log-test-braces")(Level::info, "rig {emulated} 100%");
  EXPECT_THAT(c.out.str(), ::testing::EndsWith("[info] log-test-braces: rig {emulated} 100%\n"));
}

TEST(HostLog, InitMakesTheProgramTheDefaultAndSetsTheThreshold) {
  init("log-test-main", Level::warn);
  Capture c("log-test-main");
  EXPECT_EQ(spdlog::default_logger(), logger("log-test-main"));
  spdlog::info("not written");
  spdlog::warn("trigger: {} failed", "udp send");
  to_spdlog()(Level::err, "through the default");
  to_spdlog()(Level::debug, "below the threshold");
  const std::string out = c.out.str();
  EXPECT_EQ(out.find("not written"), std::string::npos);
  EXPECT_EQ(out.find("below the threshold"), std::string::npos);
  EXPECT_NE(out.find("[warning] log-test-main: trigger: udp send failed\n"), std::string::npos);
  EXPECT_NE(out.find("[error] log-test-main: through the default\n"), std::string::npos);
  // A logger made after init() has its threshold.
  EXPECT_EQ(logger("log-test-later")->level(), Level::warn);
  init("log-test-main", Level::info);
  EXPECT_EQ(logger("log-test-later")->level(), Level::info);
}

TEST(HostLog, OrSpdlogKeepsTheOwnersFn) {
  std::vector<std::pair<Level, std::string>> lines;
  Fn fn = or_spdlog([&](Level level, const std::string& line) { lines.emplace_back(level, line); },
                    "log-test-own");
  Capture c("log-test-own");
  fn(Level::warn, "captured");
  EXPECT_THAT(lines, ElementsAre(Pair(Level::warn, "captured")));
  EXPECT_EQ(c.out.str(), "");

  Fn fallback = or_spdlog({}, "log-test-own");
  ASSERT_TRUE(fallback);
  fallback(Level::info, "to spdlog");
  EXPECT_THAT(c.out.str(), ::testing::EndsWith("[info] log-test-own: to spdlog\n"));
}

}  // namespace
}  // namespace vc::log
