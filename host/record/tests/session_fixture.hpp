// Test data for host/record: temp folders, rig files, and deterministic records shaped like what the
// host writes (human-shaped hulls from proto's test shapes, features of front nodes, poses, stats).
// Everything is a pure function of its arguments, so a test can re-create what a record must hold.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "voxcap/record/recorder.hpp"

namespace vc::record::testing {

// A fresh folder under the system temp directory, removed with everything in it on destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

struct RigFiles {
  std::filesystem::path rig_toml;
  std::filesystem::path calibration_yaml;
};
// Writes <dir>/<name>.toml (`name = "<name>"`, a 16^3 grid, nodes front0, side1, side2) and
// <dir>/<name>.yaml (a stub: the recorder copies it, nothing here loads it).
RigFiles write_rig_files(const std::filesystem::path& dir, const std::string& name = "testrig");

// Human-shaped hull in a grid_n^3 grid, RLE-encoded; *occupied receives its occupied voxel count.
std::vector<uint8_t> hull_rle(int grid_n, uint64_t seed, uint64_t* occupied);

// Frame `seq`: nodes 0..2 present, every 7th frame degraded with node 2 missing, trigger times 60 Hz.
// grid_n == 0 leaves the hull out. Hulls cycle through 8 poses so building many frames stays cheap.
FrameRecord make_frame(uint64_t seq, int grid_n = 16);
FeatureRecord make_features(uint64_t seq, uint16_t node_id, uint16_t camera);
PoseRecord make_pose(uint64_t seq, bool with_names);
StatsRecord make_stats(uint64_t t_ns, uint16_t node_id);

// A host-like session: per frame seq (first_seq, first_seq+1, ...): the frame, the features of both
// cameras of node 0, the pose (names in the first), and a stats record of node seq%3 every 10 frames.
std::vector<Record> make_session_records(uint64_t first_seq, size_t frames, int grid_n = 16);

void append(Recorder& recorder, const Record& record);

// Equal down to every bit (floats by their bits, so NaN == NaN): compares the records' encodings.
bool same_record(const Record& a, const Record& b);

// The bytes of records.vcr of a session holding `records`, closed or not (written through a Recorder
// in a temp folder).
std::vector<uint8_t> session_bytes(const std::vector<Record>& records, bool close);

// Start offsets of the records of a valid records.vcr (BEGIN first), plus its size at the end.
std::vector<uint64_t> record_offsets(std::span<const uint8_t> records_vcr);

std::vector<uint8_t> read_bytes(const std::filesystem::path& path);
void write_bytes(const std::filesystem::path& path, std::span<const uint8_t> bytes);

}  // namespace vc::record::testing
