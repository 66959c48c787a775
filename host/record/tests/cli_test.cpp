// `voxcap session info|dump` end to end: the real binary on sessions written by the library —
// closed, cut (torn tail), and not a session at all — checking what it prints and its exit codes.
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "session_fixture.hpp"
#include "voxcap/record/pose.hpp"
#include "voxcap/record/recorder.hpp"

namespace vc::record {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

struct CliRun {
  int code = -1;
  std::string out;
};

// Runs voxcap with `args` (stderr merged into stdout when `merge`), returns exit code and output.
CliRun voxcap(const std::string& args, bool merge = false) {
  const std::string cmd = std::string("'") + VOXCAP_CLI + "' " + args + (merge ? " 2>&1" : " 2>/dev/null");
  CliRun r;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int status = ::pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

class RecordCli : public ::testing::Test {
 protected:
  void SetUp() override {
    const testing::RigFiles rig = testing::write_rig_files(tmp.path(), "studio");
    closed = tmp.path() / "closed";
    Recorder rec = Recorder::create(closed, rig.rig_toml, rig.calibration_yaml, R"({"take": 7})");
    for (const Record& r : testing::make_session_records(10, 20)) testing::append(rec, r);
    rec.close();

    cut = tmp.path() / "cut";
    Recorder rec2 = Recorder::create(cut, rig.rig_toml, rig.calibration_yaml, "");
    for (const Record& r : testing::make_session_records(0, 5)) testing::append(rec2, r);
    const uint64_t size = rec2.bytes();
    ::truncate((cut / "records.vcr").c_str(), static_cast<off_t>(size - 10));  // tear the last record
  }
  testing::TempDir tmp;
  fs::path closed, cut;
};

TEST_F(RecordCli, InfoJsonOfAClosedSession) {
  const CliRun r = voxcap("session info --json '" + closed.string() + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["rig_name"], "studio");
  EXPECT_EQ(j["frames"], 20);
  EXPECT_EQ(j["first_seq"], 10);
  EXPECT_EQ(j["last_seq"], 29);
  EXPECT_EQ(j["degraded_frames"], 3);  // seqs 10, 17, 24
  EXPECT_EQ(j["features"], 40);
  EXPECT_EQ(j["poses"], 20);
  EXPECT_EQ(j["stats"], 2);  // seqs 19, 29
  EXPECT_NEAR(j["duration_s"].get<double>(), 19 * 0.016666667, 1e-6);
  ASSERT_EQ(j["nodes"].size(), 3u);
  EXPECT_EQ(j["nodes"][1]["id"], 1);
  EXPECT_EQ(j["nodes"][1]["name"], "side1");  // from the session's copy of rig.toml
  EXPECT_EQ(j["nodes"][2]["frames_missing"], 3);
  EXPECT_EQ(j["closed_cleanly"], true);
  EXPECT_EQ(j["stop"], "closed");
  EXPECT_EQ(j["truncated_bytes"], 0);
  EXPECT_EQ(j["rig_toml_ok"], true);
  EXPECT_EQ(j["meta"]["take"], 7);
  EXPECT_EQ(j["joint_names"].size(), 11u);
  EXPECT_EQ(voxcap("session info --strict '" + closed.string() + "'").code, 0);
}

TEST_F(RecordCli, InfoTextOfACutSession) {
  const CliRun r = voxcap("session info '" + cut.string() + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("rig       studio"));
  EXPECT_THAT(r.out, HasSubstr("frames    5 (1 degraded), seq 0 .. 4"));
  EXPECT_THAT(r.out, HasSubstr("poses     4 records"));  // the torn last record was the pose of seq 4
  EXPECT_THAT(r.out, HasSubstr("cut, torn tail of"));
  EXPECT_THAT(r.out, HasSubstr("node 0 (front0)"));
  EXPECT_THAT(r.out, HasSubstr("bytes ignored"));
  // --strict turns a cut session into exit code 1, after printing.
  const CliRun strict = voxcap("session info --strict '" + cut.string() + "'", true);
  EXPECT_EQ(strict.code, 1);
  EXPECT_THAT(strict.out, HasSubstr("session is torn"));

  const auto j = nlohmann::json::parse(voxcap("session info --json '" + cut.string() + "'").out);
  EXPECT_EQ(j["closed_cleanly"], false);
  EXPECT_EQ(j["stop"], "torn");
  EXPECT_GT(j["truncated_bytes"].get<int>(), 0);
}

TEST_F(RecordCli, DumpPrintsRecordsInOrder) {
  const CliRun r = voxcap("session dump --type frame --json '" + closed.string() + "'");
  ASSERT_EQ(r.code, 0);
  std::vector<nlohmann::json> lines;
  size_t start = 0;
  for (size_t nl; (nl = r.out.find('\n', start)) != std::string::npos; start = nl + 1)
    lines.push_back(nlohmann::json::parse(r.out.substr(start, nl - start)));
  ASSERT_EQ(lines.size(), 20u);
  for (size_t i = 0; i < lines.size(); ++i) {
    EXPECT_EQ(lines[i]["type"], "frame");
    EXPECT_EQ(lines[i]["seq"], 10 + i);
  }
  const CliRun text = voxcap("session dump --limit 3 '" + closed.string() + "'");
  EXPECT_EQ(text.code, 0);
  EXPECT_THAT(text.out, HasSubstr("frame    seq 10"));
  EXPECT_THAT(text.out, HasSubstr("features seq 10"));
  EXPECT_EQ(std::count(text.out.begin(), text.out.end(), '\n'), 3);
}

// Fitted poses (layout voxcap.pose15/1) are printed decoded: state, body version, joints by name.
TEST_F(RecordCli, DumpPrintsFittedPosesByJointName) {
  const testing::RigFiles rig = testing::write_rig_files(tmp.path(), "fitted");
  const fs::path dir = tmp.path() / "fitted-session";
  {
    Recorder rec = Recorder::create(dir, rig.rig_toml, rig.calibration_yaml, "");
    PoseRecord r;
    for (uint64_t seq = 5; seq < 8; ++seq) {
      pipeline::Pose p;
      p.state = seq == 5 ? pipeline::PoseState::None : pipeline::PoseState::Fitted;
      p.body_version = seq == 5 ? 0 : 3;
      p.t_fitted_ns = 123;
      p.p_world[static_cast<size_t>(pipeline::PoseJoint::l_wrist)] = {0.5, -0.25, 1.5};
      to_record(seq, p, seq == 5, &r);
      rec.append(r);
    }
    rec.close();
  }
  const CliRun j = voxcap("session dump --type pose --json '" + dir.string() + "'");
  ASSERT_EQ(j.code, 0) << j.out;
  std::vector<nlohmann::json> lines;
  size_t start = 0;
  for (size_t nl; (nl = j.out.find('\n', start)) != std::string::npos; start = nl + 1)
    lines.push_back(nlohmann::json::parse(j.out.substr(start, nl - start)));
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0]["state"], "none");
  EXPECT_EQ(lines[1]["state"], "fitted");
  EXPECT_EQ(lines[2]["seq"], 7);
  EXPECT_EQ(lines[2]["body_version"], 3);
  EXPECT_EQ(lines[2]["t_fitted_ns"], 123);
  EXPECT_EQ(lines[2]["p_world_m"]["l_wrist"], nlohmann::json::array({0.5, -0.25, 1.5}));
  EXPECT_EQ(lines[2]["p_world_m"].size(), 15u);
  const CliRun text = voxcap("session dump --type pose '" + dir.string() + "'");
  ASSERT_EQ(text.code, 0);
  EXPECT_THAT(text.out, HasSubstr("pose     seq 5        none body 0"));
  EXPECT_THAT(text.out, HasSubstr("pose     seq 6        fitted body 3"));
  EXPECT_THAT(text.out, HasSubstr("l_wrist (0.500, -0.250, 1.500)"));
}

TEST_F(RecordCli, BadInputIsExitCode2) {
  CliRun r = voxcap("session info '" + (tmp.path() / "nothing").string() + "'", true);
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.out, HasSubstr("no such session folder"));
  r = voxcap("session info '" + tmp.path().string() + "'", true);
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.out, HasSubstr("not a voxcap session"));
  EXPECT_EQ(voxcap("session dump --type hull '" + closed.string() + "'").code, 2);
  EXPECT_NE(voxcap("session info").code, 0);
}

}  // namespace
}  // namespace vc::record

namespace vc::record {
namespace {

// Issue #13 (recovery): one flipped byte in the first record (BEGIN) lost every frame although every
// data record after it was intact. Now `session info` reads them all and says what it skipped, and
// `session dump` prints them with the skip on stderr.
TEST_F(RecordCli, FlippedByteInTheFirstRecordLosesNoFrame) {
  const fs::path records = closed / "records.vcr";
  FILE* f = std::fopen(records.c_str(), "r+b");
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(std::fseek(f, 40, SEEK_SET), 0);  // inside BEGIN's body (its manifest copy)
  const int c = std::fgetc(f);
  ASSERT_EQ(std::fseek(f, 40, SEEK_SET), 0);
  std::fputc(c ^ 0x20, f);
  std::fclose(f);

  const CliRun r = voxcap("session info '" + closed.string() + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("frames    20"));
  EXPECT_THAT(r.out, HasSubstr("skipped   0 damaged records"));
  EXPECT_THAT(r.out, HasSubstr("record 0 (begin): bad CRC at byte 0"));
  const auto j = nlohmann::json::parse(voxcap("session info --json '" + closed.string() + "'").out);
  EXPECT_EQ(j["frames"], 20);
  EXPECT_EQ(j["rig_name"], "studio");  // from session.json
  EXPECT_EQ(j["format_version"], 3);
  EXPECT_EQ(j["stop"], "closed");
  EXPECT_EQ(j["skipped_records"], 0);
  EXPECT_GT(j["skipped_bytes"].get<int>(), 40);
  EXPECT_EQ(j["damage"].size(), 1u);

  const CliRun dump = voxcap("session dump --type frame '" + closed.string() + "'", true);
  EXPECT_EQ(dump.code, 0);
  EXPECT_EQ(std::count(dump.out.begin(), dump.out.end(), '\n'), 21) << dump.out;  // 20 frames + the skip
  EXPECT_THAT(dump.out, HasSubstr("skipped"));
}

// Issue #13: a FIFO as records.vcr hung `session info` in open(2); now it is refused at once (exit 2).
TEST_F(RecordCli, FifoAsRecordsIsRefusedWithoutHanging) {
  const fs::path dir = tmp.path() / "fifo-session";
  fs::create_directories(dir);
  ASSERT_EQ(::mkfifo((dir / "records.vcr").c_str(), 0600), 0);
  const CliRun r = voxcap("session info '" + dir.string() + "'", true);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("records.vcr: not a regular file"));
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
}

}  // namespace
}  // namespace vc::record
