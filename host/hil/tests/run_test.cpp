// host/hil's runners without devices: what each test does when the rig file names no lines (SKIPPED,
// naming the keys), bad options (HilConfigError), an unknown test, and the camera path of this build.
#include <gtest/gtest.h>

#include <string>

#include "voxcap/hil/camera.hpp"
#include "voxcap/hil/run.hpp"

namespace vc::hil {
namespace {

RunOptions real_rig_without_lines() {
  RunOptions o;
  o.emulated = false;
  o.config.name = "bench";  // defaults: udp trigger, no [hil] section
  o.pulses = 10;
  return o;
}

TEST(HilRun, TestNamesInTheirOrder) {
  EXPECT_EQ(test_names(), (std::vector<std::string>{"loopback", "edge-input", "alignment", "smoke"}));
}

TEST(HilRun, UnconfiguredLinesAreSkippedNamingTheKeys) {
  const RunOptions o = real_rig_without_lines();
  const Outcome loop = run_test("loopback", o);
  EXPECT_EQ(loop.name, "loopback");
  EXPECT_EQ(loop.verdict.status, Status::Skip);
  EXPECT_NE(loop.verdict.reason.find("[hil.loopback]"), std::string::npos) << loop.verdict.reason;
  const Outcome edge = run_test("edge-input", o);
  EXPECT_EQ(edge.verdict.status, Status::Skip);
  EXPECT_NE(edge.verdict.reason.find("[hil.edge_input]"), std::string::npos) << edge.verdict.reason;
  const Outcome align = run_test("alignment", o);
  EXPECT_EQ(align.verdict.status, Status::Skip);
  EXPECT_NE(align.verdict.reason.find("[[hil.cameras]]"), std::string::npos) << align.verdict.reason;
  const Outcome smoke = run_test("smoke", o);
  EXPECT_EQ(smoke.verdict.status, Status::Skip);
  EXPECT_NE(smoke.verdict.reason.find("smoke_seconds"), std::string::npos) << smoke.verdict.reason;
}

TEST(HilRun, BadOptionsAndNames) {
  RunOptions o = real_rig_without_lines();
  EXPECT_THROW(run_test("jitter", o), std::invalid_argument);
  o.pulses = 1;
  std::string why;
  EXPECT_FALSE(o.valid(&why));
  EXPECT_NE(why.find("pulses"), std::string::npos);
  EXPECT_THROW(run_test("loopback", o), HilConfigError);
  o.pulses = 10;
  o.edge_rates_hz = {60, 0};
  EXPECT_FALSE(o.valid(&why));
  EXPECT_NE(why.find("rates_hz"), std::string::npos);
}

TEST(HilRun, CameraPathOfThisBuild) {
  if (cameras_built_in()) {
    // With the edge part: a backend that does not exist is the device's failure, not "not built in".
    CameraSpec s;
    s.backend = "no-such-backend";
    s.device = "x";
    try {
      open_camera(s);
      ADD_FAILURE() << "opened a camera of no backend";
    } catch (const CamerasUnavailable& e) {
      ADD_FAILURE() << e.what();
    } catch (const std::runtime_error&) {
    }
  } else {
    EXPECT_THROW(open_camera(CameraSpec{}), CamerasUnavailable);
  }
}

}  // namespace
}  // namespace vc::hil
