// `voxcap hil --emulated --json`: the hardware-in-loop tests' emulated twin (udp trigger on loopback,
// sim cameras, the emulated rig) proves the test logic a real rig run uses and prints its figures.
// Run as the user runs it (the voxcap binary, its JSON, its exit code). Only counts are asserted, never
// timing: the jitter figures must be there and finite, whatever the loaded machine makes of them.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <string>

#include <nlohmann/json.hpp>

namespace {

struct CommandRun {
  std::string out;
  int exit_code = -1;
};

CommandRun run(const std::string& command) {
  CommandRun r;
  FILE* p = popen(command.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n = 0;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int status = pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

const nlohmann::json& test_named(const nlohmann::json& j, const std::string& name) {
  for (const nlohmann::json& t : j["tests"])
    if (t["name"] == name) return t;
  static const nlohmann::json none;
  ADD_FAILURE() << "no test " << name << " in " << j.dump(2);
  return none;
}

void expect_finite(const nlohmann::json& p, const char* what) {
  for (const char* k : {"p50", "p95", "p99", "max"}) {
    ASSERT_TRUE(p.contains(k)) << what << "." << k;
    ASSERT_TRUE(p[k].is_number()) << what << "." << k << " = " << p[k].dump();
    EXPECT_TRUE(std::isfinite(p[k].get<double>())) << what << "." << k;
    EXPECT_GE(p[k].get<double>(), 0) << what << "." << k;
  }
  EXPECT_LE(p["p50"].get<double>(), p["max"].get<double>()) << what;
}

// A train's figures: every pulse sent and seen once, none missed, none extra, jitter measured.
void expect_every_pulse_seen(const nlohmann::json& f, uint64_t pulses) {
  EXPECT_EQ(f["pulses"].get<uint64_t>(), pulses);
  EXPECT_EQ(f["sent"].get<uint64_t>(), pulses);
  EXPECT_EQ(f["seen"].get<uint64_t>(), pulses);
  EXPECT_EQ(f["matched"].get<uint64_t>(), pulses);
  EXPECT_EQ(f["missed"].get<uint64_t>(), 0u);
  EXPECT_EQ(f["extra"].get<uint64_t>(), 0u);
  EXPECT_EQ(f["seq_gaps"].get<uint64_t>(), 0u);
  EXPECT_EQ(f["jitter_us"]["n"].get<uint64_t>(), pulses - 1);
  expect_finite(f["jitter_us"], "jitter_us");
  ASSERT_TRUE(f["period_us"].is_number());
  EXPECT_TRUE(std::isfinite(f["period_us"].get<double>()));
}

TEST(HilEmulated, EveryTestPassesWithItsFigures) {
  const uint64_t pulses = 120;
  const CommandRun r = run(std::string(VOXCAP_BINARY) + " hil --emulated --json --pulses 120 --seconds 3");
  nlohmann::json j;
  ASSERT_NO_THROW(j = nlohmann::json::parse(r.out)) << r.out;
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_EQ(j["mode"], "emulated");
  EXPECT_EQ(j["passed"].get<int>(), 4) << j.dump(2);
  EXPECT_EQ(j["failed"].get<int>(), 0) << j.dump(2);

  const nlohmann::json& loopback = test_named(j, "loopback");
  EXPECT_EQ(loopback["status"], "PASS") << loopback["reason"];
  expect_every_pulse_seen(loopback["figures"], pulses);
  EXPECT_DOUBLE_EQ(loopback["figures"]["rate_hz"].get<double>(), 60);

  const nlohmann::json& edge = test_named(j, "edge-input");
  EXPECT_EQ(edge["status"], "PASS") << edge["reason"];
  ASSERT_EQ(edge["figures"]["rates"].size(), 2u);
  EXPECT_DOUBLE_EQ(edge["figures"]["rates"][0]["rate_hz"].get<double>(), 60);
  EXPECT_DOUBLE_EQ(edge["figures"]["rates"][1]["rate_hz"].get<double>(), 120);
  for (const nlohmann::json& f : edge["figures"]["rates"]) expect_every_pulse_seen(f, pulses);

  const nlohmann::json& align = test_named(j, "alignment");
  EXPECT_EQ(align["status"], "PASS") << align["reason"];
  EXPECT_EQ(align["figures"]["pulses_seen"].get<uint64_t>(), pulses);
  ASSERT_EQ(align["figures"]["cameras"].size(), 2u);
  for (const nlohmann::json& c : align["figures"]["cameras"]) {
    EXPECT_EQ(c["frames"].get<uint64_t>(), pulses) << "a frame per pulse";
    EXPECT_EQ(c["paired"].get<uint64_t>(), pulses);
    EXPECT_EQ(c["unpaired"].get<uint64_t>(), 0u);
    EXPECT_EQ(c["pulses_without_frame"].get<uint64_t>(), 0u);
    expect_finite(c["offset_us"], "offset_us");
    // The sim camera stamps each frame at its pulse + the latency it was given: exactly.
    EXPECT_NEAR(c["offset_us"]["p50"].get<double>(), c["latency_us"].get<double>(), 1.0);
  }

  const nlohmann::json& smoke = test_named(j, "smoke");
  EXPECT_EQ(smoke["status"], "PASS") << smoke["reason"];
  const nlohmann::json& s = smoke["figures"];
  EXPECT_EQ(s["nodes_connected"].get<int>(), s["nodes"].get<int>());
  EXPECT_GT(s["frames"].get<uint64_t>(), 0u);
  EXPECT_FALSE(s["merging_stopped"].get<bool>());
}

TEST(HilEmulated, PrintsTheFiguresAndAVerdictPerTest) {
  const CommandRun r =
      run(std::string(VOXCAP_BINARY) + " hil --emulated --tests loopback,edge-input --pulses 30 --rate 120");
  EXPECT_EQ(r.exit_code, 0) << r.out;
  for (const char* line : {"[loopback] 30 pulses at 120 Hz -> input udp 127.0.0.1:",
                           "sent 30, seen 30, matched 30, missed 0, extra 0, input counter gaps 0",
                           "jitter p50 ", "[loopback] PASS: 30 of 30 pulses seen, 0 missed, 0 extra",
                           "[edge-input] PASS: 30 pulses -> 30 events at each of 120 Hz, none missed",
                           "voxcap hil: 2 PASS, 0 FAIL, 0 SKIPPED"})
    EXPECT_NE(r.out.find(line), std::string::npos) << "missing \"" << line << "\" in\n" << r.out;
}

}  // namespace
