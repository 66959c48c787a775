// Session recording: one folder per session, one append-only data file with a CRC32C per record.
//
// A session folder holds
//   session.json      the manifest (created time, software version, rig name, the caller's meta),
//                     written once, atomically (tmp + rename);
//   rig.toml          byte-exact copy of the rig configuration used;
//   calibration.yaml  byte-exact copy of the calibration used;
//   records.vcr       the records: BEGIN, then frames / features / poses / stats in the order they were
//                     appended, then END when the session was closed. Byte layout: host/record/README.md.
//
// Recorder writes every record with a single write(2) on an O_APPEND descriptor, so a process killed
// with kill -9 leaves the file ending on a record boundary (or, for a large record cut by the kill, a
// torn tail); flush() makes it durable against power loss. Reader opens whatever is there, up to the
// last complete and valid record, and says how many bytes after it were ignored.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <variant>
#include <vector>

namespace vc::record {

// StatsRecord::node_id of statistics about the host itself rather than one edge node.
inline constexpr uint16_t kHostNodeId = 0xFFFF;

struct FrameRecord {  // one assembled frame
  uint64_t seq = 0;
  uint64_t t_trigger_ns = 0;  // the trigger edge (host clock)
  uint64_t t_merged_ns = 0;   // when the merged hull was ready (host clock)
  uint32_t grid_id = 0;
  uint64_t voxel_count = 0;  // voxels in the grid
  uint64_t occupied = 0;     // occupied voxels of the merged hull
  bool degraded = false;     // merged without every node (assembly.missing_node_policy = "degraded")
  std::vector<uint16_t> nodes_present;
  std::vector<uint16_t> nodes_missing;
  // Merged hull in the proto/ RLE format (voxcap/rle.h). Empty: the hull is not recorded. Otherwise it
  // must be canonical and its runs must sum to voxel_count with `occupied` occupied voxels.
  std::vector<uint8_t> rle;

  bool operator==(const FrameRecord&) const = default;
};

struct FeatureRecord {  // the 2D features one camera of one (front) node reported for a frame
  uint64_t seq = 0;
  uint16_t node_id = 0;
  uint16_t camera = 0;
  struct F {
    uint16_t id = 0, state = 0;
    float u = 0, v = 0, confidence = 0;  // pixels; any float bits are stored exactly (NaN included)
    bool operator==(const F&) const = default;
  };
  std::vector<F> features;

  bool operator==(const FeatureRecord&) const = default;
};

struct PoseRecord {
  uint64_t seq = 0;
  // Only in the first pose record or when they changed (the writer's convention, not enforced);
  // Reader::joint_names() carries the names in force forward.
  std::vector<std::string> joint_names;
  std::vector<double> values;  // joint parameters or positions, layout documented by the writer ...
  std::string layout;          // ... and named here (e.g. "positions_xyz_m")

  bool operator==(const PoseRecord&) const = default;
};

struct StatsRecord {  // per-node (or kHostNodeId: host) statistics as JSON text
  uint64_t t_ns = 0;
  uint16_t node_id = 0;
  std::string json;  // must be valid JSON (checked when appended)

  bool operator==(const StatsRecord&) const = default;
};

// The host's 3D features of a frame (host/triangulate, pipeline::Feature3D): one entry per feature.
struct Features3DRecord {
  uint64_t seq = 0;
  struct P {
    uint16_t id = 0;             // vc_feature_id, the performer's side
    uint8_t state = 0;           // pipeline::Feature3DState: 0 triangulated, 1 too_few_views, 2 inconsistent
    double x = 0, y = 0, z = 0;  // metres, world frame (any bits stored exactly)
    float confidence = 0, reproj_px = 0;  // 0..1; RMS reprojection error, pixels
    std::vector<uint16_t> views;          // rig camera indices used, at most kMaxViews
    // A hand's or foot's left/right naming as the triangulation trusted it (pipeline::Feature3D's
    // name_trusted; version 3: bit 7 of the state byte set when not trusted; older versions: true).
    bool name_trusted = true;
    bool operator==(const P&) const = default;
  };
  static constexpr size_t kMaxViews = 255;
  static constexpr size_t kMaxFeatures = 255;
  std::vector<P> features;

  bool operator==(const Features3DRecord&) const = default;
};

using Record = std::variant<FrameRecord, FeatureRecord, PoseRecord, StatsRecord, Features3DRecord>;

// Append-only writer. Every append() is one record with its own CRC32C, written with one write(2):
// no per-record fsync, no buffering beyond the record being written, and no allocation in steady
// state (the encode buffer grows to the largest record and stays). Appends are serialised by an
// internal mutex, so the frame thread and a stats thread may share one Recorder.
//
// Errors: a record that cannot be encoded (more than 65535 nodes, an RLE that is not canonical or
// does not match voxel_count/occupied, stats text that is not JSON, a record over 256 MiB) throws
// std::invalid_argument and writes nothing. An I/O error throws std::runtime_error; the partial
// record is cut off again (ftruncate) so the file stays readable and later appends may succeed. If
// even that fails the Recorder is broken and every later append throws.
class Recorder {
 public:
  // Creates DIR (it must not exist or be empty; missing parents are created), writes DIR/rig.toml
  // and DIR/calibration.yaml copies (from the given file paths), records.vcr with its BEGIN record,
  // and the manifest session.json, all synced to disk. The rig name is rig.toml's top-level `name`
  // (else its file stem). `session_json_meta` is a JSON object as text (or empty) stored in the
  // manifest under "meta"; anything else throws std::invalid_argument. Throws std::runtime_error with
  // a message naming the path on I/O errors, after removing what it created.
  static Recorder create(const std::filesystem::path& dir, const std::filesystem::path& rig_toml,
                         const std::filesystem::path& calibration_yaml, const std::string& session_json_meta);

  Recorder(Recorder&&) noexcept;
  Recorder& operator=(Recorder&&) noexcept;
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;
  // Closes the file WITHOUT an END record: a session not close()d reads as cut, which is honest.
  ~Recorder();

  void append(const FrameRecord& frame);
  void append(const FeatureRecord& features);
  void append(const PoseRecord& pose);
  void append(const StatsRecord& stats);
  void append(const Features3DRecord& features3d);

  // fdatasync: everything appended so far survives a power loss. write(2) already happened per record,
  // so a kill -9 loses nothing appended even without flush(). Called by the host every ~1 s.
  void flush();
  // Writes the END record, syncs and closes. Idempotent; appends after close() throw std::logic_error.
  void close();

  uint64_t records() const;  // data records appended (frames + features + poses + stats)
  uint64_t bytes() const;    // size of records.vcr, BEGIN and END included
  const std::filesystem::path& dir() const;

 private:
  struct Impl;
  explicit Recorder(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Opens a possibly cut or damaged session: up to its last complete, valid record, skipping damaged
// records in between (Summary::skipped_*). open() scans and validates the whole file once (computing
// the Summary); next() then iterates the same records again, each decoded and validated in full. A session
// still being recorded reads as cut at its current end. Not thread-safe: one Reader per thread.
class Reader {
 public:
  enum class Stop : uint8_t {
    Closed,     // the END record: the session was closed cleanly
    EndOfFile,  // the file ends on a record boundary without END (cut by kill -9 between writes)
    TornTail,   // the file ends inside a record, or in zeros (cut during a write, or power loss)
    Corrupt,    // a record with bad magic / CRC / structure and no valid record after it: reading stops there
  };

  struct NodeCounts {
    uint64_t frames_present = 0;  // frames whose merged hull includes this node
    uint64_t frames_missing = 0;  // frames this node was missing from
    uint64_t feature_records = 0;
    uint64_t stats_records = 0;
  };

  struct Summary {
    // Counts of valid records (the brief's fields first).
    uint64_t frames = 0, degraded_frames = 0, features = 0, poses = 0, stats = 0;
    uint64_t features3d = 0;               // Features3DRecords (format version 2 on)
    uint64_t first_seq = 0, last_seq = 0;  // seq of the first and the last frame record; 0 without frames
    bool closed_cleanly = false;           // an END record, and no damaged record skipped on the way
    uint64_t truncated_bytes = 0;  // bytes after the last valid record that were ignored (torn/corrupt tail)
    // Damage skipped in the middle (the reader resynchronises at the next valid record): the record
    // numbers missing and the bytes passed over, and one line per damaged stretch (the first 100):
    // "record 0 (begin): bad CRC at byte 0: 96 bytes skipped (1 record), reading on at record 1".
    uint64_t skipped_records = 0, skipped_bytes = 0;
    std::vector<std::string> damage;
    std::string rig_name;

    uint64_t records = 0;         // data records (frames + features + poses + stats + features3d)
    uint64_t feature_points = 0;  // FeatureRecord::F entries in all feature records
    uint64_t hull_frames = 0;     // frames with a recorded hull
    uint64_t hull_bytes = 0;      // RLE bytes of all recorded hulls
    uint64_t missing_seqs = 0;    // seqs skipped between consecutive frame records (dropped frames)
    uint64_t unordered_seqs = 0;  // frame records whose seq is not above the previous one
    uint64_t first_trigger_ns = 0, last_trigger_ns = 0;  // of the first and last frame record
    uint64_t max_merge_latency_ns = 0;                   // max over frames of t_merged_ns - t_trigger_ns
    double mean_merge_latency_ns = 0;
    // Every node id seen in frames, features or stats (not kHostNodeId).
    std::map<uint16_t, NodeCounts> nodes;
    std::vector<std::string> joint_names;  // the last joint names recorded
    std::string pose_layout;               // the last pose layout recorded

    Stop stop = Stop::EndOfFile;
    // Why reading stopped, with the record number and byte offset: "record 57 (frame): bad CRC at byte 1234".
    std::string stop_detail;
    uint64_t file_bytes = 0;   // size of records.vcr when opened
    uint64_t valid_bytes = 0;  // bytes up to the end of the last valid record

    uint32_t format_version = 0;   // from the BEGIN record (0: no valid BEGIN)
    int64_t created_unix_ns = 0;   // CLOCK_REALTIME when the session was created
    uint64_t created_mono_ns = 0;  // CLOCK_MONOTONIC at the same instant (the clock of trigger times)
    std::string software_version;  // voxcap version that wrote it
    std::string meta_json;         // the caller's meta object, as JSON text ("{}" when none)
    bool rig_toml_ok = false;      // DIR/rig.toml exists and matches the manifest's CRC32C
    bool calibration_ok = false;   // DIR/calibration.yaml likewise
    std::vector<std::string> rig_node_ids;  // `id` of each [[nodes]] in DIR/rig.toml, in file order
    std::vector<std::string> warnings;      // problems that do not stop reading (manifest unreadable, ...)

    double duration_s() const;  // (last_trigger_ns - first_trigger_ns) / 1e9
  };

  // Throws std::runtime_error if DIR is not a directory, has no records.vcr, or its records.vcr is not
  // a regular file (a FIFO or a device is refused at once, never waited on). A missing or broken
  // session.json is only a warning: the BEGIN record holds a copy of the manifest.
  static Reader open(const std::filesystem::path& dir);
  // The same over the bytes of a records.vcr held in memory (no folder, no manifest file): for tests,
  // fuzzing and tools.
  static Reader from_bytes(std::vector<uint8_t> records_vcr);

  Reader(Reader&&) noexcept;
  Reader& operator=(Reader&&) noexcept;
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;
  ~Reader();

  Summary summary() const;
  const Summary& summary_ref() const;

  // Iteration over the data records in file order, each fully validated; false after the last valid
  // one. `out` is reused: when it already holds the same alternative its vectors keep their capacity.
  bool next(Record& out);
  void rewind();  // next() starts again from the first record
  // The joint names in force for the last PoseRecord next() returned (the last non-empty names seen).
  const std::vector<std::string>& joint_names() const;

 private:
  struct Impl;
  explicit Reader(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

const char* to_string(Reader::Stop stop);

}  // namespace vc::record
