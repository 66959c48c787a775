// Cut and damaged sessions: a records.vcr cut at any byte reopens with exactly the records before the
// cut; any single damaged byte skips exactly its record and reading goes on after it; zero-filled
// tails (power loss), bytes after END, and lost, repeated or swapped records are all caught.
#include <unistd.h>

#include <filesystem>
#include <string>
#include <variant>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "session_fixture.hpp"
#include "voxcap/record/format.hpp"
#include "voxcap/record/recorder.hpp"
#include "voxcap/record/session_info.hpp"

namespace vc::record {
namespace {

namespace fs = std::filesystem;
using testing::make_session_records;
using testing::record_offsets;
using testing::same_record;
using testing::session_bytes;

// Reads every record next() gives and checks them against the first records of `expected`.
size_t read_and_compare(Reader& reader, const std::vector<Record>& expected) {
  Record r;
  size_t n = 0;
  while (reader.next(r)) {
    if (n >= expected.size() || !same_record(r, expected[n])) {
      ADD_FAILURE() << "record " << n << " differs from what was written";
      return n;
    }
    ++n;
  }
  return n;
}

class RecordCrash : public ::testing::Test {
 protected:
  // 6 frames with their features, poses and stats; the last record is a frame (hull of a 16^3 grid).
  void SetUp() override {
    records = make_session_records(500, 6);
    records.emplace_back(testing::make_frame(506));
    bytes = session_bytes(records, /*close=*/false);
    offsets = record_offsets(bytes);
    ASSERT_EQ(offsets.size(), records.size() + 2);  // BEGIN + data records + end of file
  }
  std::vector<Record> records;
  std::vector<uint8_t> bytes;
  std::vector<uint64_t> offsets;  // offsets[0] = BEGIN, offsets[i] = data record i-1, back() = size
};

// The brief's test: truncated at every byte offset of its last record, the session reopens with
// exactly the previous records, and says how many bytes of torn tail it ignored.
TEST_F(RecordCrash, CutInsideTheLastRecordKeepsEverythingBefore) {
  const uint64_t last = offsets[offsets.size() - 2];
  ASSERT_GT(bytes.size() - last, 100u);
  for (uint64_t cut = last; cut <= bytes.size(); ++cut) {
    Reader reader = Reader::from_bytes({bytes.begin(), bytes.begin() + static_cast<ptrdiff_t>(cut)});
    const Reader::Summary& s = reader.summary_ref();
    const size_t want = cut == bytes.size() ? records.size() : records.size() - 1;
    ASSERT_EQ(s.records, want) << "cut at " << cut;
    ASSERT_EQ(read_and_compare(reader, records), want) << "cut at " << cut;
    ASSERT_FALSE(s.closed_cleanly);
    ASSERT_EQ(s.valid_bytes, want == records.size() ? cut : last);
    ASSERT_EQ(s.truncated_bytes, cut - s.valid_bytes) << "cut at " << cut;
    const Reader::Stop stop =
        (cut == last || cut == bytes.size()) ? Reader::Stop::EndOfFile : Reader::Stop::TornTail;
    ASSERT_EQ(s.stop, stop) << "cut at " << cut << ": " << s.stop_detail;
    ASSERT_EQ(s.frames, want == records.size() ? 7u : 6u);
    ASSERT_EQ(s.last_seq, want == records.size() ? 506u : 505u);
  }
}

// Stronger: a cut anywhere in the file keeps exactly the records that end before the cut.
TEST_F(RecordCrash, CutAnywhereKeepsTheCompleteRecords) {
  size_t complete = 0;  // data records ending at or before the cut
  for (uint64_t cut = 0; cut <= bytes.size(); ++cut) {
    while (complete < records.size() && offsets[complete + 2] <= cut) ++complete;
    Reader reader = Reader::from_bytes({bytes.begin(), bytes.begin() + static_cast<ptrdiff_t>(cut)});
    const Reader::Summary& s = reader.summary_ref();
    ASSERT_EQ(s.records, complete) << "cut at " << cut;
    ASSERT_EQ(read_and_compare(reader, records), complete) << "cut at " << cut;
    const uint64_t valid = cut < offsets[1] ? 0 : offsets[complete + 1];
    ASSERT_EQ(s.valid_bytes, valid) << "cut at " << cut;
    ASSERT_EQ(s.truncated_bytes, cut - valid);
    ASSERT_NE(s.stop, Reader::Stop::Corrupt) << "cut at " << cut << ": " << s.stop_detail;
  }
}

// The same through real files, truncated with truncate(2), for a handful of cuts.
TEST_F(RecordCrash, CutFilesReopen) {
  testing::TempDir tmp;
  const testing::RigFiles rig = testing::write_rig_files(tmp.path());
  const fs::path dir = tmp.path() / "s";
  {
    Recorder rec = Recorder::create(dir, rig.rig_toml, rig.calibration_yaml, "");
    for (const Record& r : records) testing::append(rec, r);
  }
  const fs::path file = dir / "records.vcr";
  const std::vector<uint8_t> written = testing::read_bytes(file);  // BEGIN differs from `bytes` (time, paths)
  const uint64_t last = record_offsets(written).end()[-2];
  for (uint64_t cut : {written.size() - 1, last + 30, last + 23, last + 1}) {
    ASSERT_EQ(::truncate(file.c_str(), static_cast<off_t>(cut)), 0);
    Reader reader = Reader::open(dir);
    EXPECT_EQ(reader.summary().records, records.size() - 1);
    EXPECT_EQ(reader.summary().truncated_bytes, cut - last);
    EXPECT_EQ(reader.summary().stop, Reader::Stop::TornTail);
    EXPECT_EQ(read_and_compare(reader, records), records.size() - 1);
  }
}

// Any single byte of a middle record damaged (two different flips per byte): reading stops right
// before that record, with every earlier record intact and the rest of the file reported.
// Issue #13 (recovery): a damaged record is skipped and reading goes on at the next valid one. (This
// replaces "a damaged byte stops reading at its record": every record after it is now read, and the
// skip is reported exactly: one record, its bytes, its number.)
TEST_F(RecordCrash, DamagedByteSkipsOnlyItsRecord) {
  const size_t k = records.size() / 2;  // data record k sits at offsets[k + 1]
  const uint64_t begin = offsets[k + 1], end = offsets[k + 2];
  std::vector<Record> expected = records;
  expected.erase(expected.begin() + static_cast<ptrdiff_t>(k));
  for (uint64_t at = begin; at < end; ++at) {
    for (uint8_t flip : {uint8_t{0x01}, uint8_t{0xFF}}) {
      std::vector<uint8_t> damaged = bytes;
      damaged[at] ^= flip;
      Reader reader = Reader::from_bytes(std::move(damaged));
      const Reader::Summary& s = reader.summary_ref();
      ASSERT_EQ(s.records, records.size() - 1) << "byte " << at << " ^ " << int{flip};
      ASSERT_EQ(s.stop, Reader::Stop::EndOfFile) << "byte " << at << ": " << s.stop_detail;
      ASSERT_EQ(s.skipped_records, 1u);
      ASSERT_EQ(s.skipped_bytes, end - begin);
      ASSERT_EQ(s.valid_bytes, bytes.size());
      ASSERT_EQ(s.truncated_bytes, 0u);
      ASSERT_FALSE(s.closed_cleanly);
      ASSERT_EQ(s.damage.size(), 1u);
      ASSERT_THAT(s.damage[0], ::testing::HasSubstr("record " + std::to_string(k + 1)));
      ASSERT_THAT(s.damage[0], ::testing::HasSubstr("at byte " + std::to_string(begin)));
      ASSERT_THAT(s.stop_detail, ::testing::HasSubstr("skipped 1 damaged record"));
      ASSERT_EQ(read_and_compare(reader, expected), expected.size());
      reader.rewind();  // the iteration skips the same record again
      ASSERT_EQ(read_and_compare(reader, expected), expected.size());
    }
  }
}

// The case: one flipped byte in the first record (BEGIN) lost every frame; now every data
// record after it is read. (Replaces "a damaged BEGIN yields nothing".)
TEST_F(RecordCrash, DamagedBeginRecordIsSkipped) {
  for (uint64_t at : {uint64_t{0}, uint64_t{7}, uint64_t{30}, offsets[1] - 1}) {
    std::vector<uint8_t> damaged = bytes;
    damaged[at] ^= 0x40;
    Reader reader = Reader::from_bytes(std::move(damaged));
    const Reader::Summary& s = reader.summary_ref();
    EXPECT_EQ(s.records, records.size()) << "byte " << at;
    EXPECT_EQ(s.frames, 7u);
    EXPECT_EQ(s.skipped_records, 0u);  // BEGIN is not a data record; its bytes are skipped
    EXPECT_EQ(s.skipped_bytes, offsets[1]);
    EXPECT_EQ(s.format_version, 0u);  // unknown without BEGIN (Reader::open takes session.json's)
    EXPECT_EQ(s.stop, Reader::Stop::EndOfFile);
    EXPECT_EQ(s.truncated_bytes, 0u);
    EXPECT_THAT(s.warnings, ::testing::Contains(::testing::HasSubstr("BEGIN record is damaged")));
    EXPECT_EQ(read_and_compare(reader, records), records.size());
  }
}

// Damage in several places, and a closed session: END counts the records lost.
TEST_F(RecordCrash, SeveralDamagedRecordsInAClosedSession) {
  std::vector<uint8_t> closed = session_bytes(records, /*close=*/true);
  for (size_t k : {1u, 4u, 5u, 9u}) closed[offsets[k + 1] + 26] ^= 0x10;  // inside each record's body
  Reader reader = Reader::from_bytes(std::move(closed));
  const Reader::Summary& s = reader.summary_ref();
  EXPECT_EQ(s.records, records.size() - 4);
  EXPECT_EQ(s.skipped_records, 4u);
  EXPECT_EQ(s.damage.size(), 3u);  // records 5 and 6 (data 4, 5) are one stretch
  EXPECT_EQ(s.stop, Reader::Stop::Closed);
  EXPECT_FALSE(s.closed_cleanly);
  EXPECT_THAT(s.stop_detail, ::testing::HasSubstr("END counts " + std::to_string(records.size())));
  std::vector<Record> expected;
  for (size_t i = 0; i < records.size(); ++i)
    if (i != 1 && i != 4 && i != 5 && i != 9) expected.push_back(records[i]);
  EXPECT_EQ(read_and_compare(reader, expected), expected.size());
}

// Issue #13: a run's summary (voxcap rig, voxcap-host, voxcap demo) counts what its session holds, read
// back as `session info` reads it: a damaged frame record is a frame fewer, a skipped record and a
// merged frame the session does not hold, and the summary's line says each.
TEST_F(RecordCrash, RunSummaryCountsWhatTheSessionHolds) {
  size_t frames = 0, frame_k = 0;
  for (size_t i = 0; i < records.size(); ++i)
    if (std::holds_alternative<FrameRecord>(records[i])) frame_k = (frames++ == 2) ? i : frame_k;
  std::vector<uint8_t> closed = session_bytes(records, /*close=*/true);
  {
    Reader whole = Reader::from_bytes(closed);
    const RunRecording r = read_back(whole.summary_ref(), "S", frames);
    EXPECT_EQ(r.frames, frames);
    EXPECT_EQ(r.records, records.size());
    EXPECT_TRUE(r.complete());
    EXPECT_EQ(run_recording_line(r), "session   S: " + std::to_string(frames) + " frames (of " +
                                         std::to_string(frames) + " merged), " +
                                         std::to_string(records.size()) + " records, closed cleanly");
  }
  closed[offsets[frame_k + 1] + 26] ^= 0x10;  // inside the third frame record's body
  Reader damaged = Reader::from_bytes(std::move(closed));
  const RunRecording r = read_back(damaged.summary_ref(), "S", frames);
  EXPECT_EQ(r.frames, frames - 1);
  EXPECT_EQ(r.records, records.size() - 1);
  EXPECT_EQ(r.skipped_records, 1u);
  EXPECT_EQ(r.skipped_bytes, offsets[frame_k + 2] - offsets[frame_k + 1]);
  EXPECT_EQ(r.frames_not_recorded(), 1u);
  EXPECT_FALSE(r.complete());
  EXPECT_EQ(r.damage.size(), 1u);
  const std::string line = run_recording_line(r);
  EXPECT_THAT(line, ::testing::HasSubstr(std::to_string(frames - 1) + " frames (of " +
                                         std::to_string(frames) + " merged)"));
  EXPECT_THAT(line, ::testing::HasSubstr("closed with damage, 1 damaged record skipped ("));
  EXPECT_THAT(line, ::testing::HasSubstr("1 merged frame NOT in the session"));
}

// Power loss on ext4 can leave the tail of the file zero-filled: a torn tail, not corruption.
TEST_F(RecordCrash, ZeroFilledTailIsATornTail) {
  for (size_t zeros : {1u, 23u, 24u, 5000u}) {
    std::vector<uint8_t> b = bytes;
    b.resize(b.size() + zeros, 0);
    const Reader reader = Reader::from_bytes(std::move(b));
    EXPECT_EQ(reader.summary().records, records.size());
    EXPECT_EQ(reader.summary().stop, Reader::Stop::TornTail) << reader.summary().stop_detail;
    EXPECT_EQ(reader.summary().truncated_bytes, zeros);
  }
  // The last record's bytes zeroed, as when its pages never reached the disk.
  std::vector<uint8_t> b = bytes;
  std::fill(b.begin() + static_cast<ptrdiff_t>(offsets[offsets.size() - 2]), b.end(), 0);
  EXPECT_EQ(Reader::from_bytes(std::move(b)).summary().stop, Reader::Stop::TornTail);
  // Garbage instead of zeros is corruption.
  b = bytes;
  b.push_back(0x17);
  EXPECT_EQ(Reader::from_bytes(std::move(b)).summary().stop, Reader::Stop::Corrupt);
}

TEST_F(RecordCrash, BytesAfterEndAreReported) {
  std::vector<uint8_t> closed = session_bytes(records, /*close=*/true);
  const size_t size = closed.size();
  closed.insert(closed.end(), {1, 2, 3});
  const Reader reader = Reader::from_bytes(std::move(closed));
  const Reader::Summary& s = reader.summary_ref();
  EXPECT_TRUE(s.closed_cleanly);
  EXPECT_EQ(s.records, records.size());
  EXPECT_EQ(s.valid_bytes, size);
  EXPECT_EQ(s.truncated_bytes, 3u);
  EXPECT_THAT(s.warnings, ::testing::Contains(::testing::HasSubstr("after the END record")));
}

// Records with valid CRCs in the wrong place: the record numbers catch them.
TEST_F(RecordCrash, LostRepeatedOrSwappedRecordsAreCaught) {
  auto span_of = [&](size_t data_index) {
    return std::vector<uint8_t>(bytes.begin() + static_cast<ptrdiff_t>(offsets[data_index + 1]),
                                bytes.begin() + static_cast<ptrdiff_t>(offsets[data_index + 2]));
  };
  auto head = [&](size_t data_records) {
    return std::vector<uint8_t>(bytes.begin(),
                                bytes.begin() + static_cast<ptrdiff_t>(offsets[data_records + 1]));
  };
  const size_t k = 5;
  std::vector<uint8_t> repeated = head(k + 1);  // record k twice
  const std::vector<uint8_t> rec_k = span_of(k);
  repeated.insert(repeated.end(), rec_k.begin(), rec_k.end());
  Reader r1 = Reader::from_bytes(std::move(repeated));
  EXPECT_EQ(r1.summary().records, k + 1);
  EXPECT_EQ(r1.summary().stop, Reader::Stop::Corrupt);
  EXPECT_THAT(r1.summary().stop_detail, ::testing::HasSubstr("lost or repeated"));

  // A lost record is now reported as skipped and the record after it read (was: reading stopped, k).
  std::vector<uint8_t> lost = head(k);  // record k missing
  const std::vector<uint8_t> rec_k1 = span_of(k + 1);
  lost.insert(lost.end(), rec_k1.begin(), rec_k1.end());
  const Reader r2 = Reader::from_bytes(std::move(lost));
  EXPECT_EQ(r2.summary().records, k + 1);
  EXPECT_EQ(r2.summary().skipped_records, 1u);
  EXPECT_EQ(r2.summary().skipped_bytes, 0u);

  // Swapped: the later one is read (one record lost before it); the earlier one after it is refused.
  std::vector<uint8_t> swapped = head(k);
  swapped.insert(swapped.end(), rec_k1.begin(), rec_k1.end());
  swapped.insert(swapped.end(), rec_k.begin(), rec_k.end());
  const Reader r3 = Reader::from_bytes(std::move(swapped));
  EXPECT_EQ(r3.summary().records, k + 1);
  EXPECT_EQ(r3.summary().skipped_records, 1u);
  EXPECT_EQ(r3.summary().stop, Reader::Stop::Corrupt);
  EXPECT_THAT(r3.summary().stop_detail, ::testing::HasSubstr("lost or repeated"));
}

TEST_F(RecordCrash, ArbitraryBytesAreNotASession) {
  std::vector<uint8_t> junk(4096);
  for (size_t i = 0; i < junk.size(); ++i) junk[i] = static_cast<uint8_t>(i * 131 + 7);
  const Reader reader = Reader::from_bytes(junk);
  EXPECT_EQ(reader.summary().records, 0u);
  EXPECT_EQ(reader.summary().stop, Reader::Stop::Corrupt);
  EXPECT_EQ(reader.summary().truncated_bytes, junk.size());
  EXPECT_EQ(Reader::from_bytes({}).summary().stop, Reader::Stop::EndOfFile);
}

}  // namespace
}  // namespace vc::record
