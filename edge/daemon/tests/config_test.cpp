#include "config.hpp"

#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

namespace {

std::string write_tmp(const std::string& text) {
  char path[] = "/tmp/voxcap-edge-XXXXXX.toml";
  int fd = mkstemps(path, 5);
  EXPECT_GE(fd, 0);
  close(fd);
  std::ofstream(path) << text;
  return path;
}

std::string load_error(const std::string& text) {
  std::string p = write_tmp(text);
  vc::edge::EdgeSettings s;
  try {
    vc::edge::load_edge_toml(p, s);
    s.validate();
  } catch (const vc::edge::ConfigError& e) {
    std::remove(p.c_str());
    return e.what();
  }
  std::remove(p.c_str());
  return "";
}

TEST(EdgeConfig, FullFileLoads) {
  std::string p = write_tmp(R"(
node_id = 2
[host]
address = "10.0.0.1"
port = 7701
[[cameras]]
backend = "v4l2"
device = "/dev/video0"
width = 640
height = 480
format = "yuyv"
fps = 60
[[cameras]]
backend = "libcamera"
device = "0"
exposure_us = 4000
latency_us = 150
[trigger]
backend = "gpiod"
chip = "gpiochip4"
line = 17
bias = "pull-down"
[link]
queue_messages = 32
)");
  vc::edge::EdgeSettings s;
  vc::edge::load_edge_toml(p, s);
  s.validate();
  std::remove(p.c_str());
  vc_edged_options o = vc::edge::to_options(s);
  EXPECT_EQ(o.node_id, 2);
  EXPECT_STREQ(o.cameras[0].backend, "v4l2");
  EXPECT_EQ(o.cameras[0].pixfmt, VC_PIXFMT_YUYV);
  EXPECT_EQ(o.cameras[0].index, 4);  // node 2, camera 0
  EXPECT_EQ(o.cameras[1].exposure_us, 4000);
  EXPECT_EQ(o.camera_latency_ns[1], 150000);
  EXPECT_STREQ(o.trigger.backend, "gpiod");
  EXPECT_EQ(o.trigger.line_offset, 17u);
  EXPECT_EQ(o.trigger.bias, VC_TRIGGER_BIAS_PULL_DOWN);
  EXPECT_EQ(o.link.port, 7701);
  EXPECT_EQ(o.link.queue_msgs, 32u);
}

TEST(EdgeConfig, CameraOptionsGoToTheBackendAsGiven) {
  std::string p = write_tmp(R"(
[[cameras]]
backend = "file"
device = "/data/take1"
options = "pace=1,loop=1"
[[cameras]]
backend = "file"
device = "/data/take1"
)");
  vc::edge::EdgeSettings s;
  vc::edge::load_edge_toml(p, s);
  s.validate();
  std::remove(p.c_str());
  vc_edged_options o = vc::edge::to_options(s);
  EXPECT_STREQ(o.cameras[0].options, "pace=1,loop=1");
  EXPECT_EQ(o.cameras[1].options, nullptr);
}

TEST(EdgeConfig, ErrorsNameTheKey) {
  EXPECT_NE(load_error("nodeid = 1\n").find("nodeid: unknown key"), std::string::npos);
  EXPECT_NE(load_error("[host]\nport = 0\n").find("host.port"), std::string::npos);
  EXPECT_NE(load_error("[host]\nport = \"x\"\n").find("host.port: must be an integer"), std::string::npos);
  EXPECT_NE(load_error("[[cameras]]\nbackend=\"sim\"\n").find("exactly two"), std::string::npos);
  EXPECT_NE(
      load_error("[[cameras]]\nbackend=\"usb\"\ndevice=\"x\"\n[[cameras]]\n").find("cameras[0].backend"),
      std::string::npos);
  EXPECT_NE(load_error("[trigger]\nbackend = \"gpiod\"\n").find("trigger.line"), std::string::npos);
  EXPECT_NE(load_error("[link]\nheartbeat_ms = 100\nhost_timeout_ms = 50\n").find("link.host_timeout_ms"),
            std::string::npos);
  EXPECT_NE(load_error("[trigger\n").find(".toml:"), std::string::npos);  // parse error with position
  EXPECT_NE(load_error("next_key = \"rig.key.next\"\n").find("next_key: needs key"), std::string::npos);
  // A value quoted in the error stays on one line (edge_fuzz_edge_toml's find: a "\n" in a backend).
  const std::string e = load_error("[[cameras]]\nbackend=\"sim\\nx\"\ndevice=\"x\"\n[[cameras]]\n");
  EXPECT_NE(e.find("cameras[0].backend"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << e;
}

// A rotation under way: both key files, relative to edge.toml's folder, read and handed to the link and
// the trigger (either key is proved; host/deploy/README.md "Keys").
TEST(EdgeConfig, NextKeyDuringARotationReachesLinkAndTrigger) {
  const std::string p = write_tmp("");
  const std::string a = p + ".a", b = p + ".b", base = p.substr(p.rfind('/') + 1);
  std::ofstream(p) << "key = \"" << base << ".a\"\nnext_key = \"" << base << ".b\"\n";
  std::ofstream(a) << std::string(64, '1') << "\n";
  std::ofstream(b) << std::string(64, '2') << "\n";
  chmod(a.c_str(), 0600);
  chmod(b.c_str(), 0600);
  vc::edge::EdgeSettings s;
  vc::edge::load_edge_toml(p, s);
  s.validate();
  vc::edge::load_key(s);
  EXPECT_EQ(s.next_key, b);
  ASSERT_EQ(s.key_bytes.size(), 32u);
  ASSERT_EQ(s.next_key_bytes.size(), 32u);
  EXPECT_EQ(s.key_bytes[0], 0x11);
  EXPECT_EQ(s.next_key_bytes[0], 0x22);
  const vc_edged_options o = vc::edge::to_options(s);
  EXPECT_EQ(o.link.next_key, s.next_key_bytes.data());
  EXPECT_EQ(o.trigger.next_key, s.next_key_bytes.data());
  std::remove(a.c_str());
  std::remove(b.c_str());
  std::remove(p.c_str());
}

TEST(EdgeConfig, DefaultsAreTheEmulatedNode) {
  vc::edge::EdgeSettings s;
  s.validate();
  vc_edged_options o = vc::edge::to_options(s);
  EXPECT_STREQ(o.trigger.backend, "udp");
  EXPECT_EQ(o.trigger.port, 47000);
  EXPECT_STREQ(o.cameras[0].backend, "sim");
}

}  // namespace

namespace {

// Issue #13: numbers that wrapped or were not finite became a configuration; now each is one line.
TEST(EdgeConfig, OutOfRangeAndNonFiniteValuesAreRefused) {
  EXPECT_NE(load_error("node_id = 4294967296\n").find("node_id: 4294967296 is out of range"),
            std::string::npos);
  EXPECT_NE(load_error("node_id = -5\n").find("node_id: must be in 0..65535, got -5"), std::string::npos);
  EXPECT_NE(load_error("[host]\nport = 99999999999\n").find("host.port: 99999999999 is out of range"),
            std::string::npos);
  EXPECT_NE(
      load_error("[[cameras]]\nfps = nan\n[[cameras]]\n").find("cameras[0].fps: must be a finite number"),
      std::string::npos);
  EXPECT_NE(
      load_error("[trigger]\ntolerance_us = inf\n").find("trigger.tolerance_us: must be a finite number"),
      std::string::npos);
  EXPECT_NE(
      load_error("[trigger]\nmax_delay_ms = 1e300\n").find("trigger.max_delay_ms: must be in (0, 10000]"),
      std::string::npos);
  EXPECT_NE(
      load_error("[[cameras]]\nindex = -7\n[[cameras]]\n").find("cameras[0].index: must be in 0..65535"),
      std::string::npos);
  EXPECT_NE(load_error("[[cameras]]\nlatency_us = -1\n[[cameras]]\n").find("cameras[0].latency_us"),
            std::string::npos);
  EXPECT_NE(load_error("[log]\nverbosity = 9\n").find("log.verbosity: must be 0, 1 or 2"), std::string::npos);
  EXPECT_NE(load_error("[link]\nstats_ms = 2147483647\n").find("link.stats_ms: must be in 10..600000"),
            std::string::npos);
  EXPECT_NE(load_error("[trigger]\nline = -3\n").find("trigger.line: must be in 0..65535"),
            std::string::npos);
}

TEST(EdgeConfig, OnlyABoundedRegularFileIsRead) {
  char dir[] = "/tmp/voxcap-edge-fifo-XXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  const std::string fifo = std::string(dir) + "/edge.toml";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  vc::edge::EdgeSettings s;
  try {
    vc::edge::load_edge_toml(fifo, s);  // returns at once: no writer is needed to refuse it
    ADD_FAILURE() << "a FIFO was read";
  } catch (const vc::edge::ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), fifo + ": not a regular file (a FIFO)");
  }
  std::remove(fifo.c_str());
  const std::string big = write_tmp("# " + std::string(vc::edge::kMaxEdgeTomlBytes, 'x') + "\n");
  try {
    vc::edge::load_edge_toml(big, s);
    ADD_FAILURE() << "an oversized file was read";
  } catch (const vc::edge::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("larger than 1048576 bytes"), std::string::npos) << e.what();
  }
  std::remove(big.c_str());
  rmdir(dir);
}

}  // namespace

namespace {

// The example the voxcap-edge package installs as /etc/voxcap/edge.toml (deploy/packaging/edge.toml):
// it loads and validates, for the reference rig's Pi 5 (two GS cameras at 1456x1088, GPIO18).
TEST(EdgeConfig, PackagedExampleLoads) {
  vc::edge::EdgeSettings s;
  vc::edge::load_edge_toml(VOXCAP_SOURCE_DIR "/deploy/packaging/edge.toml", s);
  s.validate();
  vc_edged_options o = vc::edge::to_options(s);
  EXPECT_EQ(o.node_id, 1);
  EXPECT_STREQ(o.cameras[0].backend, "libcamera");
  EXPECT_STREQ(o.cameras[1].backend, "libcamera");
  EXPECT_STREQ(o.trigger.backend, "gpiod");
  EXPECT_EQ(s.gpio_line_name, "GPIO18");
}

}  // namespace
