// The host killed with kill -9 while it records: `voxcap rig --emulated --record` runs in its own
// process group; after it has recorded for a while the whole group (host and edges) gets SIGKILL at
// once, like a power cut. The session must open up to its last complete frame.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <thread>

#include "voxcap/record/recorder.hpp"
#include "voxcap/rle.h"

extern char** environ;

namespace {

namespace fs = std::filesystem;

TEST(HostKill, SessionReopensUpToItsLastCompleteFrame) {
  char tmp[] = "/tmp/voxcap-kill-XXXXXX";
  ASSERT_NE(mkdtemp(tmp), nullptr);
  fs::path dir = tmp;
  std::vector<std::string> args = {VOXCAP_BINARY, "rig", "--emulated", "--nodes", "3", "--size", "160x120",
                                   "--grid", "48", "--truth-every", "0", "--seconds", "60",
                                   "--record", (dir / "rec").string(), "--workdir", (dir / "work").string()};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attr, 0);  // its own group: the edges it starts join it
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, argv[0], nullptr, &attr, argv.data(), environ), 0);
  posix_spawnattr_destroy(&attr);

  // Wait until frames are being recorded (bounded), then cut the power.
  auto end = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  uint64_t frames = 0;
  while (std::chrono::steady_clock::now() < end && frames < 120) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (!fs::exists(dir / "rec")) continue;
    for (auto& e : fs::directory_iterator(dir / "rec")) {
      try {
        frames = vc::record::Reader::open(e.path()).summary().frames;
      } catch (const std::exception&) {
      }
    }
  }
  kill(-pid, SIGKILL);
  int st = 0;
  waitpid(pid, &st, 0);
  ASSERT_GE(frames, 120u) << "the rig did not record in time";

  fs::path session;
  for (auto& e : fs::directory_iterator(dir / "rec")) session = e.path();
  vc::record::Reader r = vc::record::Reader::open(session);
  vc::record::Reader::Summary s = r.summary();
  EXPECT_FALSE(s.closed_cleanly);
  EXPECT_GE(s.frames, frames);
  EXPECT_EQ(s.unordered_seqs, 0u);
  EXPECT_TRUE(s.rig_toml_ok);
  EXPECT_TRUE(s.calibration_ok);
  // Every frame it gives back is whole: its hull decodes to the recorded counts.
  vc::record::Record rec;
  uint64_t seen = 0;
  while (r.next(rec)) {
    if (auto* f = std::get_if<vc::record::FrameRecord>(&rec)) {
      uint64_t occ = 0, total = 0;
      ASSERT_EQ(vc_rle_popcount(f->rle.data(), f->rle.size(), &occ, &total), 0);
      EXPECT_EQ(total, f->voxel_count);
      EXPECT_EQ(occ, f->occupied);
      seen++;
    }
  }
  EXPECT_EQ(seen, s.frames);
  RecordProperty("frames_recovered", std::to_string(seen));
  RecordProperty("torn_tail_bytes", std::to_string(s.truncated_bytes));
  fs::remove_all(dir);
}

}  // namespace
