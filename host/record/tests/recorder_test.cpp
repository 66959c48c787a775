// Recorder + Reader through real files: the session folder's contents, round trips of host-like
// sessions, closed vs cut, rejected records, concurrent appends, the manifest fallback, and the
// roll-back of a record whose write failed half-way (file size limit in a child process).
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "session_fixture.hpp"
#include "voxcap/record/format.hpp"
#include "voxcap/record/recorder.hpp"

namespace vc::record {
namespace {

namespace fs = std::filesystem;
using testing::append;
using ::testing::HasSubstr;
using testing::make_frame;
using testing::make_session_records;
using testing::make_stats;
using testing::read_bytes;
using testing::same_record;
using testing::TempDir;
using testing::write_rig_files;

class RecordSession : public ::testing::Test {
 protected:
  TempDir tmp;
  testing::RigFiles rig = write_rig_files(tmp.path());
  fs::path dir = tmp.path() / "sessions" / "s1";

  Recorder create(const std::string& meta = "{}") {
    return Recorder::create(dir, rig.rig_toml, rig.calibration_yaml, meta);
  }
  std::vector<Record> read_all(Reader& reader) {
    std::vector<Record> out;
    Record r;
    while (reader.next(r)) out.push_back(r);
    return out;
  }
};

TEST_F(RecordSession, CreateWritesTheSessionFolder) {
  Recorder rec = create(R"({"operator": "ana", "take": 3})");
  EXPECT_EQ(rec.dir(), dir);
  EXPECT_EQ(read_bytes(dir / "rig.toml"), read_bytes(rig.rig_toml));
  EXPECT_EQ(read_bytes(dir / "calibration.yaml"), read_bytes(rig.calibration_yaml));
  EXPECT_FALSE(fs::exists(dir / "session.json.tmp"));
  EXPECT_EQ(rec.records(), 0u);
  EXPECT_EQ(rec.bytes(), fs::file_size(dir / "records.vcr"));
  EXPECT_GT(rec.bytes(), 24u);

  const std::vector<uint8_t> manifest = read_bytes(dir / "session.json");
  const auto m = nlohmann::json::parse(manifest.begin(), manifest.end());
  EXPECT_EQ(m["format"], "voxcap-session");
  EXPECT_EQ(m["format_version"], format::kFormatVersion);
  EXPECT_EQ(format::kFormatVersion, 3u) << "FEATURES3D's naming-trust bit needs version 3";
  EXPECT_EQ(m["rig_name"], "testrig");
  EXPECT_EQ(m["meta"]["operator"], "ana");
  EXPECT_EQ(m["meta"]["take"], 3);
  EXPECT_EQ(m["files"]["records"], "records.vcr");
  EXPECT_EQ(m["files"]["rig_toml"]["path"], "rig.toml");
  EXPECT_EQ(m["files"]["rig_toml"]["source"], fs::absolute(rig.rig_toml).string());
  EXPECT_EQ(m["files"]["calibration"]["bytes"], fs::file_size(rig.calibration_yaml));
  EXPECT_TRUE(m["software_version"].is_string());
  EXPECT_GT(m["created_unix_ns"].get<int64_t>(), 1'600'000'000'000'000'000);
  EXPECT_EQ(m["created_utc"].get<std::string>().size(), 24u);  // 2024-05-01T12:00:00.123Z
}

TEST_F(RecordSession, CreateRefusesANonEmptyFolderAndAcceptsAnEmptyOne) {
  fs::create_directories(dir);
  { Recorder rec = create(); }
  try {
    create();
    FAIL() << "created a session over another";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("not empty"));
  }
  const fs::path file = tmp.path() / "plain";
  testing::write_bytes(file, std::vector<uint8_t>{1});
  EXPECT_THROW(Recorder::create(file, rig.rig_toml, rig.calibration_yaml, ""), std::runtime_error);
}

TEST_F(RecordSession, CreateFailsCleanlyOnBadInput) {
  try {
    Recorder::create(dir, rig.rig_toml, tmp.path() / "nope.yaml", "");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("nope.yaml"));
    EXPECT_THAT(e.what(), HasSubstr("No such file"));
  }
  EXPECT_FALSE(fs::exists(dir));
  EXPECT_THROW(create("[1, 2]"), std::invalid_argument);
  EXPECT_THROW(create("{\"a\": "), std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir));

  testing::write_bytes(rig.rig_toml, std::vector<uint8_t>{'n', 'a', 'm', 'e', ' ', '=', '='});
  try {
    create();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("not valid TOML"));
  }
}

TEST_F(RecordSession, RigNameDefaultsToTheFileStem) {
  const fs::path toml = tmp.path() / "studio-b.toml";
  testing::write_bytes(toml, std::vector<uint8_t>{'v', '=', '1', '\n'});
  Recorder rec = Recorder::create(dir, toml, rig.calibration_yaml, "");
  rec.close();
  const Reader reader = Reader::open(dir);
  EXPECT_EQ(reader.summary().rig_name, "studio-b");
  EXPECT_EQ(reader.summary().meta_json, "{}");
}

// What a host writes at 60 fps, closed: every record back, bit for bit, and a summary that adds up.
TEST_F(RecordSession, ClosedSessionRoundTrips) {
  const std::vector<Record> records = make_session_records(100, 30);
  Recorder rec = create(R"({"take": 1})");
  for (const Record& r : records) append(rec, r);
  EXPECT_EQ(rec.records(), records.size());
  rec.flush();
  rec.close();
  EXPECT_EQ(rec.bytes(), fs::file_size(dir / "records.vcr"));

  Reader reader = Reader::open(dir);
  const std::vector<Record> back = read_all(reader);
  ASSERT_EQ(back.size(), records.size());
  for (size_t i = 0; i < back.size(); ++i) EXPECT_TRUE(same_record(back[i], records[i])) << "record " << i;

  const Reader::Summary s = reader.summary();
  EXPECT_TRUE(s.closed_cleanly);
  EXPECT_EQ(s.stop, Reader::Stop::Closed);
  EXPECT_EQ(s.truncated_bytes, 0u);
  EXPECT_EQ(s.valid_bytes, s.file_bytes);
  EXPECT_EQ(s.rig_name, "testrig");
  EXPECT_TRUE(s.rig_toml_ok);
  EXPECT_TRUE(s.calibration_ok);
  EXPECT_THAT(s.rig_node_ids, ::testing::ElementsAre("front0", "side1", "side2"));
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  EXPECT_EQ(s.format_version, 3u);
  EXPECT_EQ(nlohmann::json::parse(s.meta_json)["take"], 1);
  EXPECT_EQ(s.records, records.size());
  EXPECT_EQ(s.frames, 30u);
  size_t degraded = 0, stats = 0;
  for (uint64_t seq = 100; seq < 130; ++seq) {
    degraded += seq % 7 == 3;
    stats += seq % 10 == 9;
  }
  EXPECT_EQ(s.degraded_frames, degraded);
  EXPECT_EQ(s.features, 60u);
  EXPECT_EQ(s.feature_points, 300u);
  EXPECT_EQ(s.poses, 30u);
  EXPECT_EQ(s.stats, stats);
  EXPECT_EQ(s.first_seq, 100u);
  EXPECT_EQ(s.last_seq, 129u);
  EXPECT_EQ(s.missing_seqs, 0u);
  EXPECT_EQ(s.unordered_seqs, 0u);
  EXPECT_NEAR(s.duration_s(), 29 * 0.016666667, 1e-6);
  EXPECT_EQ(s.hull_frames, 30u);
  EXPECT_EQ(s.max_merge_latency_ns, 2'400'000u);
  EXPECT_EQ(s.pose_layout, "positions_xyz_m");
  EXPECT_EQ(s.joint_names.size(), 11u);
  ASSERT_EQ(s.nodes.size(), 3u);
  EXPECT_EQ(s.nodes.at(0).frames_present, 30u);
  EXPECT_EQ(s.nodes.at(0).feature_records, 60u);
  EXPECT_EQ(s.nodes.at(2).frames_present, 30u - degraded);
  EXPECT_EQ(s.nodes.at(2).frames_missing, degraded);

  // Joint names are carried forward while iterating; rewind starts over.
  reader.rewind();
  Record r;
  size_t poses = 0;
  while (reader.next(r))
    if (std::holds_alternative<PoseRecord>(r)) {
      ++poses;
      EXPECT_EQ(reader.joint_names().size(), 11u);
    }
  EXPECT_EQ(poses, 30u);
}

TEST_F(RecordSession, SessionWithoutCloseReadsAsCutWithEverythingInIt) {
  const std::vector<Record> records = make_session_records(0, 12);
  {
    Recorder rec = create();
    for (const Record& r : records) append(rec, r);
  }  // destroyed without close(): no END record
  Reader reader = Reader::open(dir);
  const Reader::Summary s = reader.summary();
  EXPECT_FALSE(s.closed_cleanly);
  EXPECT_EQ(s.stop, Reader::Stop::EndOfFile);
  EXPECT_EQ(s.truncated_bytes, 0u);
  EXPECT_EQ(read_all(reader).size(), records.size());
}

TEST_F(RecordSession, GapsAndReorderedSeqsAreCounted) {
  Recorder rec = create();
  for (uint64_t seq : {10, 11, 14, 15, 13, 20}) rec.append(make_frame(seq, 0));
  rec.close();
  const Reader::Summary s = Reader::open(dir).summary();
  EXPECT_EQ(s.frames, 6u);
  EXPECT_EQ(s.first_seq, 10u);
  EXPECT_EQ(s.last_seq, 20u);
  EXPECT_EQ(s.missing_seqs, 2u + 6u);  // 12, 13 then 16..19 after 13 (counted from the previous record)
  EXPECT_EQ(s.unordered_seqs, 1u);
  EXPECT_EQ(s.hull_frames, 0u);
}

TEST_F(RecordSession, InvalidRecordsWriteNothing) {
  Recorder rec = create();
  rec.append(make_frame(1));
  const uint64_t bytes = rec.bytes();
  FrameRecord bad = make_frame(2);
  bad.occupied += 1;
  EXPECT_THROW(rec.append(bad), std::invalid_argument);
  EXPECT_THROW(rec.append(StatsRecord{1, 1, "not json"}), std::invalid_argument);
  EXPECT_EQ(rec.bytes(), bytes);
  EXPECT_EQ(fs::file_size(dir / "records.vcr"), bytes);
  EXPECT_EQ(rec.records(), 1u);
  rec.append(make_frame(2));
  rec.close();
  const Reader::Summary s = Reader::open(dir).summary();
  EXPECT_TRUE(s.closed_cleanly);
  EXPECT_EQ(s.frames, 2u);
}

TEST_F(RecordSession, CloseIsFinal) {
  Recorder rec = create();
  rec.append(make_stats(1, kHostNodeId));
  rec.close();
  const uint64_t bytes = rec.bytes();
  rec.close();
  rec.flush();
  EXPECT_THROW(rec.append(make_frame(1)), std::logic_error);
  EXPECT_EQ(bytes, fs::file_size(dir / "records.vcr"));
  const Reader::Summary s = Reader::open(dir).summary();
  EXPECT_EQ(s.stats, 1u);
  EXPECT_TRUE(s.nodes.empty());  // host stats belong to no node
}

// A frame thread and a stats thread sharing one Recorder: every record lands whole.
TEST_F(RecordSession, ConcurrentAppendsAreSerialised) {
  Recorder rec = create();
  constexpr uint64_t kFrames = 400, kStats = 400;
  std::thread frames([&] {
    for (uint64_t seq = 0; seq < kFrames; ++seq) rec.append(make_frame(seq));
  });
  std::thread stats([&] {
    for (uint64_t i = 0; i < kStats; ++i) rec.append(make_stats(i, 1));
  });
  frames.join();
  stats.join();
  rec.close();
  Reader reader = Reader::open(dir);
  const Reader::Summary s = reader.summary();
  EXPECT_TRUE(s.closed_cleanly);
  EXPECT_EQ(s.frames, kFrames);
  EXPECT_EQ(s.stats, kStats);
  EXPECT_EQ(s.missing_seqs + s.unordered_seqs, 0u);
}

TEST_F(RecordSession, ManifestCopyInRecordsIsTheFallback) {
  Recorder rec = create(R"({"k": "v"})");
  rec.append(make_frame(1));
  rec.close();
  fs::remove(dir / "session.json");
  testing::write_bytes(dir / "rig.toml", std::vector<uint8_t>{'#'});
  const Reader::Summary s = Reader::open(dir).summary();
  EXPECT_EQ(s.rig_name, "testrig");
  EXPECT_EQ(nlohmann::json::parse(s.meta_json)["k"], "v");
  EXPECT_FALSE(s.rig_toml_ok);
  EXPECT_TRUE(s.calibration_ok);
  EXPECT_EQ(s.frames, 1u);
  EXPECT_THAT(s.warnings, ::testing::Contains(HasSubstr("copy of the manifest")));
  EXPECT_THAT(s.warnings, ::testing::Contains(HasSubstr("rig.toml does not match")));
}

TEST_F(RecordSession, OpenRejectsWhatIsNotASession) {
  EXPECT_THROW(Reader::open(tmp.path() / "missing"), std::runtime_error);
  fs::create_directories(dir);
  try {
    Reader::open(dir);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("no records.vcr"));
  }
}

// A write that fails half-way (here: the file size limit) is cut off again, so the file stays
// readable and the next append lands right after the last complete record. Runs in a child process
// because it lowers RLIMIT_FSIZE.
TEST_F(RecordSession, FailedWriteIsRolledBack) {
  Recorder rec = create();
  rec.append(make_frame(0));
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    int code = 0;
    try {
      ::signal(SIGXFSZ, SIG_IGN);
      rlimit lim{};
      ::getrlimit(RLIMIT_FSIZE, &lim);
      const rlimit low{static_cast<rlim_t>(rec.bytes() + 100), lim.rlim_max};
      ::setrlimit(RLIMIT_FSIZE, &low);
      const FrameRecord big = make_frame(1, 64);  // a few KiB: the write stops at the limit
      bool threw = false;
      try {
        rec.append(big);
      } catch (const std::runtime_error&) {
        threw = true;
      }
      if (!threw)
        code = 10;
      else if (fs::file_size(dir / "records.vcr") != rec.bytes())
        code = 11;
      ::setrlimit(RLIMIT_FSIZE, &lim);
      rec.append(big);
      rec.close();
    } catch (...) {
      code = 12;
    }
    ::_exit(code);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 0) << "10: no error, 11: partial record left, 12: later append failed";
  Reader reader = Reader::open(dir);
  const Reader::Summary s = reader.summary();
  EXPECT_TRUE(s.closed_cleanly);
  EXPECT_EQ(s.frames, 2u);
  EXPECT_EQ(s.last_seq, 1u);
  EXPECT_EQ(s.truncated_bytes, 0u);
}

}  // namespace
}  // namespace vc::record
