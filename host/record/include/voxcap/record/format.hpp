// The byte format of records.vcr (host/record/README.md, FORMAT): encoding and validating decoding of
// single records. Recorder and Reader are built on this; tests and the fuzz target use it directly.
//
// A record is a 24-byte header (magic, type, body length, record index, header CRC32C), the body, and
// a CRC32C over header and body. Everything little-endian, independent of the host's byte order.
// Encoders write into a caller's buffer (resized, capacity kept) so steady-state appends do not
// allocate; decoders check every length against the bytes they were given and never read past them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "voxcap/record/recorder.hpp"

namespace vc::record::format {

inline constexpr uint32_t kMagic = 0x43525856;  // "VXRC" in file order
// BEGIN record's format_version: 3 since FEATURES3D's state byte carries the naming's trust (bit 7),
// 2 since FEATURES3D (7); the reader also reads 1 (no FEATURES3D) and 2 (every name trusted).
inline constexpr uint16_t kFormatVersion = 3;
inline constexpr uint16_t kOldestFormatVersion = 1;
inline constexpr size_t kHeaderBytes = 24;
inline constexpr size_t kTrailerBytes = 4;
inline constexpr uint32_t kMaxBodyBytes = 256u << 20;  // 256 MiB: a 256^3 hull's worst-case RLE fits

enum class RecordType : uint8_t {
  Begin = 1,
  Frame = 2,
  Features = 3,
  Pose = 4,
  Stats = 5,
  End = 6,
  Features3D = 7,
};
const char* to_string(RecordType type);  // "begin", "frame", ...; "unknown" otherwise

struct Header {
  RecordType type{};
  uint32_t body_bytes = 0;
  uint64_t index = 0;  // record number in the file, BEGIN is 0
};

// Body sizes of the fixed parts.
inline constexpr size_t kBeginFixed = 24;
inline constexpr size_t kFrameFixed = 56;
inline constexpr size_t kFeaturesFixed = 16;
inline constexpr size_t kFeatureBytes = 16;
inline constexpr size_t kPoseFixed = 16;
inline constexpr size_t kStatsFixed = 16;
inline constexpr size_t kEndBody = 16;
inline constexpr size_t kFeatures3DFixed = 12;
inline constexpr size_t kFeature3DFixed = 36;  // without its views (2 bytes each)
// FEATURES3D's state byte, bit 7 (version 3): the hand's or foot's left/right naming not trusted.
inline constexpr uint8_t kNameUntrusted = 0x80;

struct BeginRecord {
  uint16_t format_version = kFormatVersion;
  int64_t created_unix_ns = 0;
  uint64_t created_mono_ns = 0;
  std::string manifest_json;  // copy of session.json
  bool operator==(const BeginRecord&) const = default;
};

struct EndRecord {
  uint64_t data_records = 0;  // data records between BEGIN and END
  int64_t closed_unix_ns = 0;
  bool operator==(const EndRecord&) const = default;
};

// Checks a record against what the encoder and the reader require. false + *why (may be NULL) if not.
bool check(const FrameRecord& r, std::string* why);
bool check(const FeatureRecord& r, std::string* why);
bool check(const PoseRecord& r, std::string* why);
bool check(const StatsRecord& r, std::string* why);  // includes: json is valid JSON
bool check(const Features3DRecord& r, std::string* why);

// Encode one whole record (header, body, CRC) with record number `index` into `out` (resized; its
// capacity is reused). The record must pass check() (the Recorder checks before; callers of these
// directly get std::invalid_argument otherwise).
void encode(const BeginRecord& r, uint64_t index, std::vector<uint8_t>& out);
void encode(const FrameRecord& r, uint64_t index, std::vector<uint8_t>& out);
void encode(const FeatureRecord& r, uint64_t index, std::vector<uint8_t>& out);
void encode(const PoseRecord& r, uint64_t index, std::vector<uint8_t>& out);
void encode(const StatsRecord& r, uint64_t index, std::vector<uint8_t>& out);
void encode(const Features3DRecord& r, uint64_t index, std::vector<uint8_t>& out);
void encode(const EndRecord& r, uint64_t index, std::vector<uint8_t>& out);

// Header of the kHeaderBytes at `p`: false + *why on bad magic, bad header CRC, unknown type,
// nonzero reserved bytes or a body over kMaxBodyBytes.
bool decode_header(const uint8_t* p, Header* out, std::string* why);
// The record CRC of a whole record (header + body + trailer, kHeaderBytes + body + kTrailerBytes).
bool check_crc(std::span<const uint8_t> record);

// Body decoders: the body must be exactly one record's body (every count and length is checked
// against its size), and the record must pass check(). false + *why otherwise; `out` is then
// unspecified. Vectors in `out` keep their capacity.
bool decode_body(std::span<const uint8_t> body, BeginRecord* out, std::string* why);
bool decode_body(std::span<const uint8_t> body, FrameRecord* out, std::string* why);
bool decode_body(std::span<const uint8_t> body, FeatureRecord* out, std::string* why);
bool decode_body(std::span<const uint8_t> body, PoseRecord* out, std::string* why);
bool decode_body(std::span<const uint8_t> body, StatsRecord* out, std::string* why);
bool decode_body(std::span<const uint8_t> body, Features3DRecord* out, std::string* why);
bool decode_body(std::span<const uint8_t> body, EndRecord* out, std::string* why);

}  // namespace vc::record::format
