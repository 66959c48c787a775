// records.vcr byte format: encoders and validating decoders (layout: host/record/README.md, FORMAT).
//
// Why this shape: a session must survive kill -9 and power loss, so every record carries its own
// length and CRC32C and the reader can stop at the first record that is incomplete or damaged. The
// header has its own CRC so a damaged length is told apart from a record that was cut short, and a
// record number so a lost or repeated record cannot pass as valid. Integers are written byte by byte
// (little-endian) and floats by their IEEE-754 bits, so files move between machines unchanged.
#include "voxcap/record/format.hpp"

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "voxcap/crc32c.h"
#include "voxcap/proto.hpp"

namespace vc::record::format {
namespace {

bool fail(std::string* why, std::string msg) {
  if (why) *why = std::move(msg);
  return false;
}

// Little-endian writer over a buffer that is already large enough (sizes are computed up front).
class Put {
 public:
  explicit Put(uint8_t* p) : p_(p) {}
  void u8(uint8_t v) { *p_++ = v; }
  void u16(uint16_t v) {
    for (int i = 0; i < 2; ++i) *p_++ = static_cast<uint8_t>(v >> (8 * i));
  }
  void u32(uint32_t v) {
    for (int i = 0; i < 4; ++i) *p_++ = static_cast<uint8_t>(v >> (8 * i));
  }
  void u64(uint64_t v) {
    for (int i = 0; i < 8; ++i) *p_++ = static_cast<uint8_t>(v >> (8 * i));
  }
  void f32(float v) {
    uint32_t bits;
    std::memcpy(&bits, &v, 4);
    u32(bits);
  }
  void f64(double v) {
    uint64_t bits;
    std::memcpy(&bits, &v, 8);
    u64(bits);
  }
  void bytes(const void* data, size_t n) {
    if (n) std::memcpy(p_, data, n);
    p_ += n;
  }
  uint8_t* at() const { return p_; }

 private:
  uint8_t* p_;
};

// Little-endian reader that never reads past its span: every getter fails once bytes run out, and
// the caller checks ok() (or the return of need()) before trusting values.
class Get {
 public:
  explicit Get(std::span<const uint8_t> s) : p_(s.data()), end_(s.data() + s.size()) {}
  bool need(size_t n) {
    if (static_cast<size_t>(end_ - p_) < n) ok_ = false;
    return ok_;
  }
  uint8_t u8() { return need(1) ? *p_++ : 0; }
  uint16_t u16() { return static_cast<uint16_t>(le(2)); }
  uint32_t u32() { return static_cast<uint32_t>(le(4)); }
  uint64_t u64() { return le(8); }
  float f32() {
    const uint32_t bits = u32();
    float v;
    std::memcpy(&v, &bits, 4);
    return v;
  }
  double f64() {
    const uint64_t bits = u64();
    double v;
    std::memcpy(&v, &bits, 8);
    return v;
  }
  const uint8_t* take(size_t n) {
    if (!need(n)) return nullptr;
    const uint8_t* q = p_;
    p_ += n;
    return q;
  }
  size_t left() const { return static_cast<size_t>(end_ - p_); }
  bool ok() const { return ok_; }

 private:
  uint64_t le(int n) {
    if (!need(static_cast<size_t>(n))) return 0;
    uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= static_cast<uint64_t>(p_[i]) << (8 * i);
    p_ += n;
    return v;
  }
  const uint8_t* p_;
  const uint8_t* end_;
  bool ok_ = true;
};

uint32_t load_u32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 | static_cast<uint32_t>(p[2]) << 16 |
         static_cast<uint32_t>(p[3]) << 24;
}

// Sizes the buffer for a record with `body` body bytes, writes the header, returns a writer at the body.
Put begin_record(RecordType type, uint64_t index, size_t body, std::vector<uint8_t>& out) {
  if (body > kMaxBodyBytes)
    throw std::invalid_argument(
        fmt::format("{} record of {} bytes is over the {} byte limit", to_string(type), body, kMaxBodyBytes));
  out.resize(kHeaderBytes + body + kTrailerBytes);
  Put put(out.data());
  put.u32(kMagic);
  put.u8(static_cast<uint8_t>(type));
  put.u8(0);
  put.u16(0);
  put.u32(static_cast<uint32_t>(body));
  put.u64(index);
  put.u32(vc_crc32c(0, out.data(), 20));
  return put;
}

// Appends the record CRC after the body; checks the body was filled exactly.
void end_record(const Put& put, std::vector<uint8_t>& out) {
  const size_t body_end = out.size() - kTrailerBytes;
  if (put.at() != out.data() + body_end) throw std::logic_error("record encoder size mismatch");
  Put(out.data() + body_end).u32(vc_crc32c(0, out.data(), body_end));
}

template <typename R>
void require(const R& r) {
  std::string why;
  if (!check(r, &why)) throw std::invalid_argument(why);
}

size_t frame_body(const FrameRecord& r) {
  return kFrameFixed + 2 * (r.nodes_present.size() + r.nodes_missing.size()) + r.rle.size();
}

size_t pose_body(const PoseRecord& r) {
  size_t n = kPoseFixed + r.layout.size() + 8 * r.values.size();
  for (const std::string& name : r.joint_names) n += 2 + name.size();
  return n;
}

bool check_size(size_t body, const char* what, std::string* why) {
  if (body > kMaxBodyBytes)
    return fail(why,
                fmt::format("{} record of {} bytes is over the {} byte limit", what, body, kMaxBodyBytes));
  return true;
}

template <typename T>
void assign(std::vector<T>& v, const uint8_t* p, size_t n) {
  v.resize(n);
  for (size_t i = 0; i < n; ++i) v[i] = static_cast<T>(p[2 * i] | p[2 * i + 1] << 8);
}

}  // namespace

const char* to_string(RecordType type) {
  switch (type) {
    case RecordType::Begin:
      return "begin";
    case RecordType::Frame:
      return "frame";
    case RecordType::Features:
      return "features";
    case RecordType::Pose:
      return "pose";
    case RecordType::Stats:
      return "stats";
    case RecordType::End:
      return "end";
    case RecordType::Features3D:
      return "features3d";
  }
  return "unknown";
}

// ---------------------------------------------------------------------------------------------------
// check

namespace {
size_t features3d_body(const Features3DRecord& r) {
  size_t n = kFeatures3DFixed;
  for (const Features3DRecord::P& f : r.features) n += kFeature3DFixed + 2 * f.views.size();
  return n;
}
}  // namespace

bool check(const Features3DRecord& r, std::string* why) {
  if (r.features.size() > Features3DRecord::kMaxFeatures)
    return fail(why, fmt::format("features3d seq {}: {} features are too many", r.seq, r.features.size()));
  for (const Features3DRecord::P& f : r.features) {
    if (f.views.size() > Features3DRecord::kMaxViews)
      return fail(why, fmt::format("features3d seq {}: feature {} has {} views, at most {}", r.seq, f.id,
                                   f.views.size(), Features3DRecord::kMaxViews));
    if (f.state > 2)
      return fail(why, fmt::format("features3d seq {}: feature {} state {}", r.seq, f.id, f.state));
  }
  return true;
}

bool check(const FrameRecord& r, std::string* why) {
  if (r.nodes_present.size() > 0xFFFF || r.nodes_missing.size() > 0xFFFF)
    return fail(why, fmt::format("frame seq {}: more than 65535 nodes present or missing", r.seq));
  if (r.occupied > r.voxel_count)
    return fail(why,
                fmt::format("frame seq {}: occupied {} > voxel_count {}", r.seq, r.occupied, r.voxel_count));
  if (!check_size(frame_body(r), "frame", why)) return false;
  if (!r.rle.empty()) {
    vc_rle_info info{};
    try {
      info = proto::rle_inspect(r.rle);
    } catch (const proto::ProtoError& e) {
      return fail(
          why, fmt::format("frame seq {}: hull RLE is malformed ({})", r.seq, vc_proto_strerror(e.code())));
    }
    if (info.total != r.voxel_count || info.occupied != r.occupied)
      return fail(why, fmt::format("frame seq {}: hull RLE holds {} of {} voxels, the record says {} of {}",
                                   r.seq, info.occupied, info.total, r.occupied, r.voxel_count));
  }
  return true;
}

bool check(const FeatureRecord& r, std::string* why) {
  if (r.features.size() > (kMaxBodyBytes - kFeaturesFixed) / kFeatureBytes)
    return fail(why, fmt::format("features seq {}: {} features are too many", r.seq, r.features.size()));
  return true;
}

bool check(const PoseRecord& r, std::string* why) {
  if (r.joint_names.size() > 0xFFFF)
    return fail(why, fmt::format("pose seq {}: more than 65535 joint names", r.seq));
  if (r.layout.size() > 0xFFFF) return fail(why, fmt::format("pose seq {}: layout over 65535 bytes", r.seq));
  for (const std::string& name : r.joint_names)
    if (name.size() > 0xFFFF)
      return fail(why, fmt::format("pose seq {}: a joint name is over 65535 bytes", r.seq));
  if (r.values.size() > kMaxBodyBytes / 8)
    return fail(why, fmt::format("pose seq {}: too many values", r.seq));
  return check_size(pose_body(r), "pose", why);
}

bool check(const StatsRecord& r, std::string* why) {
  if (!check_size(kStatsFixed + r.json.size(), "stats", why)) return false;
  if (!nlohmann::json::accept(r.json))
    return fail(why, fmt::format("stats of node {} at {} ns: not valid JSON", r.node_id, r.t_ns));
  return true;
}

// ---------------------------------------------------------------------------------------------------
// encode

void encode(const BeginRecord& r, uint64_t index, std::vector<uint8_t>& out) {
  Put put = begin_record(RecordType::Begin, index, kBeginFixed + r.manifest_json.size(), out);
  put.u16(r.format_version);
  put.u16(0);
  put.u32(static_cast<uint32_t>(r.manifest_json.size()));
  put.u64(static_cast<uint64_t>(r.created_unix_ns));
  put.u64(r.created_mono_ns);
  put.bytes(r.manifest_json.data(), r.manifest_json.size());
  end_record(put, out);
}

void encode(const FrameRecord& r, uint64_t index, std::vector<uint8_t>& out) {
  require(r);
  Put put = begin_record(RecordType::Frame, index, frame_body(r), out);
  put.u64(r.seq);
  put.u64(r.t_trigger_ns);
  put.u64(r.t_merged_ns);
  put.u64(r.voxel_count);
  put.u64(r.occupied);
  put.u32(r.grid_id);
  put.u8(r.degraded ? 1 : 0);
  put.u8(0);
  put.u16(static_cast<uint16_t>(r.nodes_present.size()));
  put.u16(static_cast<uint16_t>(r.nodes_missing.size()));
  put.u16(0);
  put.u32(static_cast<uint32_t>(r.rle.size()));
  for (uint16_t n : r.nodes_present) put.u16(n);
  for (uint16_t n : r.nodes_missing) put.u16(n);
  put.bytes(r.rle.data(), r.rle.size());
  end_record(put, out);
}

void encode(const FeatureRecord& r, uint64_t index, std::vector<uint8_t>& out) {
  require(r);
  Put put =
      begin_record(RecordType::Features, index, kFeaturesFixed + kFeatureBytes * r.features.size(), out);
  put.u64(r.seq);
  put.u16(r.node_id);
  put.u16(r.camera);
  put.u32(static_cast<uint32_t>(r.features.size()));
  for (const FeatureRecord::F& f : r.features) {
    put.u16(f.id);
    put.u16(f.state);
    put.f32(f.u);
    put.f32(f.v);
    put.f32(f.confidence);
  }
  end_record(put, out);
}

// FEATURES3D (7): `0` u64 seq · `8` u16 count · `10` u16 reserved 0 · then count × (u16 id, u8 state
// (bit 7, version 3: the left/right naming not trusted), u8 n_views, f64 x, f64 y, f64 z, f32 confidence, f32
// reproj_px, n_views × u16 camera).
void encode(const Features3DRecord& r, uint64_t index, std::vector<uint8_t>& out) {
  require(r);
  Put put = begin_record(RecordType::Features3D, index, features3d_body(r), out);
  put.u64(r.seq);
  put.u16(static_cast<uint16_t>(r.features.size()));
  put.u16(0);
  for (const Features3DRecord::P& f : r.features) {
    put.u16(f.id);
    put.u8(static_cast<uint8_t>(f.state | (f.name_trusted ? 0u : kNameUntrusted)));
    put.u8(static_cast<uint8_t>(f.views.size()));
    put.f64(f.x);
    put.f64(f.y);
    put.f64(f.z);
    put.f32(f.confidence);
    put.f32(f.reproj_px);
    for (uint16_t v : f.views) put.u16(v);
  }
  end_record(put, out);
}

void encode(const PoseRecord& r, uint64_t index, std::vector<uint8_t>& out) {
  require(r);
  Put put = begin_record(RecordType::Pose, index, pose_body(r), out);
  put.u64(r.seq);
  put.u32(static_cast<uint32_t>(r.values.size()));
  put.u16(static_cast<uint16_t>(r.joint_names.size()));
  put.u16(static_cast<uint16_t>(r.layout.size()));
  put.bytes(r.layout.data(), r.layout.size());
  for (const std::string& name : r.joint_names) {
    put.u16(static_cast<uint16_t>(name.size()));
    put.bytes(name.data(), name.size());
  }
  for (double v : r.values) put.f64(v);
  end_record(put, out);
}

void encode(const StatsRecord& r, uint64_t index, std::vector<uint8_t>& out) {
  require(r);
  Put put = begin_record(RecordType::Stats, index, kStatsFixed + r.json.size(), out);
  put.u64(r.t_ns);
  put.u16(r.node_id);
  put.u16(0);
  put.u32(static_cast<uint32_t>(r.json.size()));
  put.bytes(r.json.data(), r.json.size());
  end_record(put, out);
}

void encode(const EndRecord& r, uint64_t index, std::vector<uint8_t>& out) {
  Put put = begin_record(RecordType::End, index, kEndBody, out);
  put.u64(r.data_records);
  put.u64(static_cast<uint64_t>(r.closed_unix_ns));
  end_record(put, out);
}

// ---------------------------------------------------------------------------------------------------
// decode

bool decode_header(const uint8_t* p, Header* out, std::string* why) {
  const uint32_t magic = load_u32(p);
  if (magic != kMagic) return fail(why, fmt::format("bad magic 0x{:08x}", magic));
  if (load_u32(p + 20) != vc_crc32c(0, p, 20)) return fail(why, "bad header CRC");
  const uint8_t type = p[4];
  if (type < static_cast<uint8_t>(RecordType::Begin) || type > static_cast<uint8_t>(RecordType::Features3D))
    return fail(why, fmt::format("unknown record type {} (written by a newer voxcap?)", type));
  if (p[5] != 0 || p[6] != 0 || p[7] != 0) return fail(why, "nonzero reserved header bytes");
  const uint32_t body = load_u32(p + 8);
  if (body > kMaxBodyBytes) return fail(why, fmt::format("body of {} bytes is over the limit", body));
  out->type = static_cast<RecordType>(type);
  out->body_bytes = body;
  uint64_t index = 0;
  for (int i = 0; i < 8; ++i) index |= static_cast<uint64_t>(p[12 + i]) << (8 * i);
  out->index = index;
  return true;
}

bool check_crc(std::span<const uint8_t> record) {
  if (record.size() < kHeaderBytes + kTrailerBytes) return false;
  const size_t n = record.size() - kTrailerBytes;
  return load_u32(record.data() + n) == vc_crc32c(0, record.data(), n);
}

bool decode_body(std::span<const uint8_t> body, BeginRecord* out, std::string* why) {
  Get get(body);
  out->format_version = get.u16();
  const uint16_t reserved = get.u16();
  const uint32_t manifest_len = get.u32();
  out->created_unix_ns = static_cast<int64_t>(get.u64());
  out->created_mono_ns = get.u64();
  if (!get.ok()) return fail(why, "begin record too short");
  if (out->format_version < kOldestFormatVersion || out->format_version > kFormatVersion)
    return fail(why, fmt::format("format version {} (this voxcap reads {} to {})", out->format_version,
                                 kOldestFormatVersion, kFormatVersion));
  if (reserved != 0) return fail(why, "begin record: nonzero reserved bytes");
  if (get.left() != manifest_len) return fail(why, "begin record: manifest length does not match the body");
  const uint8_t* m = get.take(manifest_len);
  out->manifest_json.assign(reinterpret_cast<const char*>(m), manifest_len);
  return true;
}

bool decode_body(std::span<const uint8_t> body, FrameRecord* out, std::string* why) {
  Get get(body);
  out->seq = get.u64();
  out->t_trigger_ns = get.u64();
  out->t_merged_ns = get.u64();
  out->voxel_count = get.u64();
  out->occupied = get.u64();
  out->grid_id = get.u32();
  const uint8_t flags = get.u8();
  const uint8_t reserved8 = get.u8();
  const uint16_t n_present = get.u16();
  const uint16_t n_missing = get.u16();
  const uint16_t reserved16 = get.u16();
  const uint32_t rle_len = get.u32();
  if (!get.ok()) return fail(why, "frame record too short");
  if ((flags & ~1u) != 0 || reserved8 != 0 || reserved16 != 0)
    return fail(why, fmt::format("frame seq {}: unknown flags or nonzero reserved bytes", out->seq));
  out->degraded = (flags & 1u) != 0;
  if (get.left() != 2 * (static_cast<size_t>(n_present) + n_missing) + rle_len)
    return fail(why, fmt::format("frame seq {}: node and RLE lengths do not match the body", out->seq));
  assign(out->nodes_present, get.take(2 * size_t{n_present}), n_present);
  assign(out->nodes_missing, get.take(2 * size_t{n_missing}), n_missing);
  const uint8_t* rle = get.take(rle_len);
  out->rle.assign(rle, rle + rle_len);
  return check(*out, why);
}

bool decode_body(std::span<const uint8_t> body, FeatureRecord* out, std::string* why) {
  Get get(body);
  out->seq = get.u64();
  out->node_id = get.u16();
  out->camera = get.u16();
  const uint32_t count = get.u32();
  if (!get.ok()) return fail(why, "features record too short");
  if (get.left() != kFeatureBytes * size_t{count})
    return fail(why, fmt::format("features seq {}: count {} does not match the body", out->seq, count));
  out->features.resize(count);
  for (FeatureRecord::F& f : out->features) {
    f.id = get.u16();
    f.state = get.u16();
    f.u = get.f32();
    f.v = get.f32();
    f.confidence = get.f32();
  }
  return get.ok() && check(*out, why);
}

bool decode_body(std::span<const uint8_t> body, Features3DRecord* out, std::string* why) {
  Get get(body);
  out->seq = get.u64();
  const uint16_t count = get.u16();
  const uint16_t reserved = get.u16();
  if (!get.ok()) return fail(why, "features3d record too short");
  if (reserved != 0) return fail(why, fmt::format("features3d seq {}: nonzero reserved bytes", out->seq));
  if (count > Features3DRecord::kMaxFeatures || get.left() < kFeature3DFixed * size_t{count})
    return fail(why, fmt::format("features3d seq {}: count {} does not match the body", out->seq, count));
  out->features.resize(count);
  for (Features3DRecord::P& f : out->features) {
    f.id = get.u16();
    const uint8_t state = get.u8();
    f.state = static_cast<uint8_t>(state & ~kNameUntrusted);
    f.name_trusted = (state & kNameUntrusted) == 0;
    const uint8_t n_views = get.u8();
    f.x = get.f64();
    f.y = get.f64();
    f.z = get.f64();
    f.confidence = get.f32();
    f.reproj_px = get.f32();
    if (!get.ok() || get.left() < 2 * size_t{n_views})
      return fail(why, fmt::format("features3d seq {}: feature {} is cut short", out->seq, f.id));
    f.views.resize(n_views);
    for (uint16_t& v : f.views) v = get.u16();
  }
  if (!get.ok() || get.left() != 0)
    return fail(why, fmt::format("features3d seq {}: the body does not match its features", out->seq));
  return check(*out, why);
}

bool decode_body(std::span<const uint8_t> body, PoseRecord* out, std::string* why) {
  Get get(body);
  out->seq = get.u64();
  const uint32_t n_values = get.u32();
  const uint16_t n_names = get.u16();
  const uint16_t layout_len = get.u16();
  const uint8_t* layout = get.take(layout_len);
  if (!get.ok()) return fail(why, "pose record too short");
  out->layout.assign(reinterpret_cast<const char*>(layout), layout_len);
  if (get.left() < 2 * size_t{n_names})
    return fail(why, fmt::format("pose seq {}: {} joint names do not fit the body", out->seq, n_names));
  out->joint_names.resize(n_names);
  for (std::string& name : out->joint_names) {
    const uint16_t len = get.u16();
    const uint8_t* p = get.take(len);
    if (!get.ok()) return fail(why, fmt::format("pose seq {}: joint names run past the body", out->seq));
    name.assign(reinterpret_cast<const char*>(p), len);
  }
  if (get.left() != 8 * size_t{n_values})
    return fail(why, fmt::format("pose seq {}: {} values do not match the body", out->seq, n_values));
  out->values.resize(n_values);
  for (double& v : out->values) v = get.f64();
  return get.ok() && check(*out, why);
}

bool decode_body(std::span<const uint8_t> body, StatsRecord* out, std::string* why) {
  Get get(body);
  out->t_ns = get.u64();
  out->node_id = get.u16();
  const uint16_t reserved = get.u16();
  const uint32_t len = get.u32();
  if (!get.ok()) return fail(why, "stats record too short");
  if (reserved != 0) return fail(why, "stats record: nonzero reserved bytes");
  if (get.left() != len) return fail(why, "stats record: text length does not match the body");
  const uint8_t* p = get.take(len);
  out->json.assign(reinterpret_cast<const char*>(p), len);
  return check(*out, why);
}

bool decode_body(std::span<const uint8_t> body, EndRecord* out, std::string* why) {
  if (body.size() != kEndBody) return fail(why, "end record has the wrong size");
  Get get(body);
  out->data_records = get.u64();
  out->closed_unix_ns = static_cast<int64_t>(get.u64());
  return true;
}

}  // namespace vc::record::format
