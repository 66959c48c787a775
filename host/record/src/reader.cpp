// The crash-tolerant session reader. It walks records.vcr from the start and accepts a record only
// when all of it is there and valid: magic, header CRC, the expected record number, a body that fits
// in the file, the record CRC, and a body whose every length and count checks out (frames: the RLE
// matches voxel_count and occupied).
//
// Damage in the middle (a flipped byte, a bad sector) is skipped: from the damaged record the reader
// scans forward for the magic of a record that reads in full (header CRC, a number above the last
// good one, record CRC, body) and goes on from there; what it skipped (records by their numbers,
// bytes, where and why) is in Summary::skipped_* and damage, and a session with skips is not
// closed_cleanly. A damaged BEGIN is skipped the same way (the manifest then comes from session.json).
// The first record that fails with no valid record after it ends the session as read; what follows is
// counted in Summary::truncated_bytes and classified: a record the file ends inside of (or a
// zero-filled tail, what a power loss leaves) is a torn tail, anything else is corruption.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

#include <fmt/format.h>
#include <toml++/toml.h>
#include <nlohmann/json.hpp>

#include "io.hpp"
#include "voxcap/crc32c.h"
#include "voxcap/record/format.hpp"
#include "voxcap/record/recorder.hpp"

namespace vc::record {
namespace fs = std::filesystem;
using format::Header;
using format::RecordType;

namespace {

constexpr size_t kReadChunk = size_t{1} << 20;
constexpr size_t kMaxDamageReports = 100;  // Summary::damage keeps the first ones

// Random access to records.vcr, from a file (buffered pread) or from memory.
class Source {
 public:
  static Source file(int fd, uint64_t size) {
    Source s;
    s.fd_ = fd;
    s.size_ = size;
    return s;
  }
  static Source memory(std::vector<uint8_t> bytes) {
    Source s;
    s.mem_ = std::move(bytes);
    s.size_ = s.mem_.size();
    return s;
  }
  Source() = default;
  Source(Source&& o) noexcept { *this = std::move(o); }
  Source& operator=(Source&& o) noexcept {
    std::swap(fd_, o.fd_);
    std::swap(size_, o.size_);
    std::swap(mem_, o.mem_);
    std::swap(buf_, o.buf_);
    std::swap(buf_off_, o.buf_off_);
    std::swap(buf_len_, o.buf_len_);
    std::swap(error_, o.error_);
    return *this;
  }
  ~Source() {
    if (fd_ >= 0) ::close(fd_);
  }

  uint64_t size() const { return size_; }
  const std::string& error() const { return error_; }

  // The n bytes at `off` (off + n <= size()), valid until the next call; nullptr on a read error
  // (error() says which) or when the file shrank under us.
  const uint8_t* get(uint64_t off, size_t n) {
    if (off > size_ || n > size_ - off) return nullptr;
    if (fd_ < 0) return mem_.data() + off;
    if (off >= buf_off_ && off + n <= buf_off_ + buf_len_) return buf_.data() + (off - buf_off_);
    const size_t want = static_cast<size_t>(std::min<uint64_t>(std::max(n, kReadChunk), size_ - off));
    if (buf_.size() < want) buf_.resize(want);
    const long long got = io::pread_all(fd_, buf_.data(), want, off);
    buf_off_ = off;
    buf_len_ = got > 0 ? static_cast<size_t>(got) : 0;
    if (got < 0) {
      error_ = fmt::format("read error at byte {}: {}", off, std::strerror(static_cast<int>(-got)));
      return nullptr;
    }
    if (buf_len_ < n) {
      error_ = fmt::format("the file shrank while reading (byte {})", off);
      return nullptr;
    }
    return buf_.data();
  }

  // True when every byte in [off, size()) is zero (what a power loss can leave after the last write).
  bool zeros_from(uint64_t off) {
    while (off < size_) {
      const size_t n = static_cast<size_t>(std::min<uint64_t>(kReadChunk, size_ - off));
      const uint8_t* p = get(off, n);
      if (!p) return false;
      if (std::any_of(p, p + n, [](uint8_t b) { return b != 0; })) return false;
      off += n;
    }
    return true;
  }

 private:
  int fd_ = -1;
  uint64_t size_ = 0;
  std::vector<uint8_t> mem_;
  std::vector<uint8_t> buf_;
  uint64_t buf_off_ = 0;
  size_t buf_len_ = 0;
  std::string error_;
};

enum class Step { Ok, Eof, Torn, Corrupt };

struct RawRecord {
  Header header;
  uint64_t offset = 0;
  uint64_t total = 0;  // header + body + trailer
  std::span<const uint8_t> body;
};

// Reads and checks the framing of the record at `off` that must have number `index`.
Step read_record(Source& src, uint64_t off, uint64_t index, RawRecord* out, std::string* why) {
  const uint64_t left = src.size() - off;
  if (left == 0) return Step::Eof;
  if (left < format::kHeaderBytes) {
    const uint8_t* p = src.get(off, static_cast<size_t>(left));
    if (!p) return *why = src.error(), Step::Corrupt;
    uint8_t magic[4] = {0x56, 0x58, 0x52, 0x43};
    if (std::memcmp(p, magic, std::min<size_t>(4, static_cast<size_t>(left))) == 0) {
      *why = fmt::format("the file ends inside the header of record {} ({} of {} bytes)", index, left,
                         format::kHeaderBytes);
      return Step::Torn;
    }
    if (src.zeros_from(off)) return *why = fmt::format("{} zero bytes at the end", left), Step::Torn;
    *why = fmt::format("record {}: bad magic", index);
    return Step::Corrupt;
  }
  const uint8_t* p = src.get(off, format::kHeaderBytes);
  if (!p) return *why = src.error(), Step::Corrupt;
  std::string problem;
  if (!format::decode_header(p, &out->header, &problem)) {
    if (src.zeros_from(off))
      return *why = fmt::format("{} zero bytes at the end (power loss?)", left), Step::Torn;
    *why = fmt::format("record {}: {}", index, problem);
    return Step::Corrupt;
  }
  const Header& h = out->header;
  if (h.index != index) {
    *why = fmt::format("record {} is numbered {} (a record lost or repeated)", index, h.index);
    return Step::Corrupt;
  }
  const uint64_t total = format::kHeaderBytes + uint64_t{h.body_bytes} + format::kTrailerBytes;
  if (total > left) {
    *why = fmt::format("the file ends inside record {} ({}, {} of {} bytes)", index,
                       format::to_string(h.type), left, total);
    return Step::Torn;
  }
  const uint8_t* rec = src.get(off, static_cast<size_t>(total));
  if (!rec) return *why = src.error(), Step::Corrupt;
  if (!format::check_crc({rec, static_cast<size_t>(total)})) {
    *why = fmt::format("record {} ({}): bad CRC", index, format::to_string(h.type));
    return Step::Corrupt;
  }
  out->offset = off;
  out->total = total;
  out->body = {rec + format::kHeaderBytes, h.body_bytes};
  return Step::Ok;
}

template <typename T>
T& holding(Record& r) {
  if (!std::holds_alternative<T>(r)) r.emplace<T>();
  return std::get<T>(r);
}

// Decodes a data record's body into `out`. false + *why when the type is not a data record or the
// body is invalid.
bool decode_data(const RawRecord& raw, Record& out, std::string* why) {
  switch (raw.header.type) {
    case RecordType::Frame:
      return format::decode_body(raw.body, &holding<FrameRecord>(out), why);
    case RecordType::Features:
      return format::decode_body(raw.body, &holding<FeatureRecord>(out), why);
    case RecordType::Pose:
      return format::decode_body(raw.body, &holding<PoseRecord>(out), why);
    case RecordType::Stats:
      return format::decode_body(raw.body, &holding<StatsRecord>(out), why);
    case RecordType::Features3D:
      return format::decode_body(raw.body, &holding<Features3DRecord>(out), why);
    case RecordType::Begin:
    case RecordType::End:
      break;
  }
  *why = fmt::format("unexpected {} record", format::to_string(raw.header.type));
  return false;
}

// After damage at `from`: the offset of the next record that reads and decodes in full and whose
// number is above `after` (a record's own magic, header CRC, record CRC and body must all agree, so a
// stray "VXRC" in a hull's bytes is not taken). false when there is none.
bool resync(Source& src, uint64_t from, uint64_t after, uint64_t* at, RawRecord* raw, Record& scratch) {
  static constexpr uint8_t kMagicBytes[4] = {0x56, 0x58, 0x52, 0x43};
  const uint64_t size = src.size();
  uint64_t off = from;
  std::string why;
  while (off + format::kHeaderBytes + format::kTrailerBytes <= size) {
    const size_t n = static_cast<size_t>(std::min<uint64_t>(kReadChunk, size - off));
    const uint8_t* p = src.get(off, n);
    if (!p) return false;
    const void* m = ::memmem(p, n, kMagicBytes, sizeof kMagicBytes);
    if (!m) {
      off += n > 3 ? n - 3 : 1;  // a magic may straddle the chunks
      continue;
    }
    const uint64_t cand = off + static_cast<uint64_t>(static_cast<const uint8_t*>(m) - p);
    const uint8_t* h = src.get(cand, format::kHeaderBytes);  // p is stale from here on
    Header header;
    if (h && format::decode_header(h, &header, &why) && header.index > after &&
        read_record(src, cand, header.index, raw, &why) == Step::Ok) {
      if (raw->header.type == RecordType::End) {
        format::EndRecord end;
        if (format::decode_body(raw->body, &end, &why)) return *at = cand, true;
      } else if (raw->header.type != RecordType::Begin && decode_data(*raw, scratch, &why)) {
        return *at = cand, true;
      }
    }
    off = cand + 1;
  }
  return false;
}

// Folds one valid data record into the summary.
class Tally {
 public:
  explicit Tally(Reader::Summary* s) : s_(s) {}

  void add(const Record& r) {
    ++s_->records;
    std::visit([this](const auto& rec) { add_one(rec); }, r);
  }

  void finish() {
    if (latency_frames_ > 0)
      s_->mean_merge_latency_ns = latency_sum_ns_ / static_cast<double>(latency_frames_);
  }

 private:
  void add_one(const FrameRecord& f) {
    Reader::Summary& s = *s_;
    if (s.frames == 0) {
      s.first_seq = f.seq;
      s.first_trigger_ns = f.t_trigger_ns;
    } else if (f.seq > s.last_seq) {
      s.missing_seqs += f.seq - s.last_seq - 1;
    } else {
      ++s.unordered_seqs;
    }
    s.last_seq = f.seq;
    s.last_trigger_ns = f.t_trigger_ns;
    ++s.frames;
    if (f.degraded) ++s.degraded_frames;
    if (!f.rle.empty()) {
      ++s.hull_frames;
      s.hull_bytes += f.rle.size();
    }
    if (f.t_merged_ns >= f.t_trigger_ns) {
      const uint64_t latency = f.t_merged_ns - f.t_trigger_ns;
      s.max_merge_latency_ns = std::max(s.max_merge_latency_ns, latency);
      latency_sum_ns_ += static_cast<double>(latency);
      ++latency_frames_;
    }
    for (uint16_t n : f.nodes_present) node(n, [](auto& c) { ++c.frames_present; });
    for (uint16_t n : f.nodes_missing) node(n, [](auto& c) { ++c.frames_missing; });
  }
  void add_one(const FeatureRecord& f) {
    ++s_->features;
    s_->feature_points += f.features.size();
    node(f.node_id, [](auto& c) { ++c.feature_records; });
  }
  void add_one(const PoseRecord& p) {
    ++s_->poses;
    if (!p.joint_names.empty()) s_->joint_names = p.joint_names;
    s_->pose_layout = p.layout;
  }
  void add_one(const Features3DRecord&) { ++s_->features3d; }
  void add_one(const StatsRecord& st) {
    ++s_->stats;
    node(st.node_id, [](auto& c) { ++c.stats_records; });
  }
  template <typename F>
  void node(uint16_t id, F&& f) {
    if (id != kHostNodeId) f(s_->nodes[id]);
  }

  Reader::Summary* s_;
  double latency_sum_ns_ = 0;
  uint64_t latency_frames_ = 0;
};

}  // namespace

struct Reader::Impl {
  Source src;
  Summary summary;
  uint64_t data_begin = 0;     // offset of the first data record (after BEGIN)
  uint64_t data_end = 0;       // offset after the last valid data record
  std::string begin_manifest;  // the manifest copy in BEGIN

  uint64_t first_index = 1;  // the number of the first data record read (above 1 after damage)
  struct Gap {
    uint64_t from, to, index;  // damage at `from`: reading goes on at `to` with record `index`
  };
  std::vector<Gap> gaps;  // in file order

  // Iteration state.
  uint64_t it_off = 0;
  uint64_t it_index = 0;
  size_t it_gap = 0;
  std::vector<std::string> joint_names;

  void scan();
  void apply_manifest(const std::string& text, const char* origin);
  void check_copies(const fs::path& dir, const nlohmann::json& manifest);
  void read_rig_nodes(const fs::path& dir);
};

void Reader::Impl::scan() {
  Summary& s = summary;
  s.file_bytes = src.size();
  RawRecord raw;
  std::string why;
  uint64_t off = 0;
  auto stop_at = [&](Stop stop, std::string detail) {
    s.stop = stop;
    s.stop_detail = std::move(detail);
    s.valid_bytes = off;
    s.truncated_bytes = s.file_bytes - off;
  };
  Record scratch;
  // Damage from `off` (record `index` expected): skip to the next valid record, or false.
  auto skip_damage = [&](uint64_t index, const std::string& what) {
    uint64_t at = 0;
    // From `off` itself: an intact record with a higher number there means records were lost.
    if (!resync(src, off, index - 1, &at, &raw, scratch)) return false;
    const uint64_t lost = raw.header.index - index;
    s.skipped_records += lost;
    s.skipped_bytes += at - off;
    if (s.damage.size() < kMaxDamageReports)
      s.damage.push_back(fmt::format("{} at byte {}: {} bytes skipped ({} record{}), reading on at record {}",
                                     what, off, at - off, lost, lost == 1 ? "" : "s", raw.header.index));
    gaps.push_back({off, at, raw.header.index});
    off = at;
    return true;
  };

  // BEGIN
  const Step first = read_record(src, 0, 0, &raw, &why);
  format::BeginRecord begin;
  if (first == Step::Ok && raw.header.type != RecordType::Begin) {
    why = fmt::format("the first record is a {} record, not BEGIN", format::to_string(raw.header.type));
  } else if (first == Step::Ok && !format::decode_body(raw.body, &begin, &why)) {
    why = "record 0 (begin): " + why;
  } else if (first == Step::Ok) {
    s.format_version = begin.format_version;
    s.created_unix_ns = begin.created_unix_ns;
    s.created_mono_ns = begin.created_mono_ns;
    begin_manifest = std::move(begin.manifest_json);
    off = raw.total;
  }
  uint64_t index = 1;
  if (off == 0) {
    data_begin = data_end = 0;
    if (first == Step::Eof) return stop_at(Stop::EndOfFile, "records.vcr is empty (no BEGIN record)");
    if (first == Step::Torn || !skip_damage(1, why)) {
      return stop_at(first == Step::Torn ? Stop::TornTail : Stop::Corrupt, why);
    }
    s.warnings.push_back("the BEGIN record is damaged: the manifest comes from session.json");
    index = raw.header.index;
  }
  data_begin = off;
  first_index = index;

  Tally tally(&s);
  for (;; ++index) {
    data_end = off;
    const Step step = read_record(src, off, index, &raw, &why);
    if (step == Step::Eof) {
      stop_at(Stop::EndOfFile, fmt::format("cut after record {}: no END record", index - 1));
      break;
    }
    if (step == Step::Torn) {
      stop_at(Stop::TornTail, why);
      break;
    }
    if (step == Step::Corrupt) {
      if (skip_damage(index, why)) {
        index = raw.header.index - 1;  // read it again below with its own number
        continue;
      }
      stop_at(Stop::Corrupt, fmt::format("{} at byte {}", why, off));
      break;
    }
    if (raw.header.type == RecordType::End) {
      format::EndRecord end;
      if (!format::decode_body(raw.body, &end, &why)) {
        const std::string what = fmt::format("record {} (end): {}", index, why);
        if (skip_damage(index, what)) {
          index = raw.header.index - 1;
          continue;
        }
        stop_at(Stop::Corrupt, fmt::format("{} at byte {}", what, off));
        break;
      }
      // With records skipped, END counts more than were read: exactly the ones lost, when the
      // damage took data records only.
      if (end.data_records != s.records && (s.skipped_records == 0 || end.data_records < s.records)) {
        stop_at(Stop::Corrupt, fmt::format("record {} (end) counts {} data records, the file has {}", index,
                                           end.data_records, s.records));
        break;
      }
      off += raw.total;
      s.closed_cleanly = s.skipped_records == 0 && s.skipped_bytes == 0;
      stop_at(Stop::Closed, "closed cleanly");
      if (s.skipped_records > 0)
        s.stop_detail =
            fmt::format("closed; END counts {} data records, {} read", end.data_records, s.records);
      if (s.truncated_bytes > 0) {
        s.stop_detail += fmt::format("; {} bytes after the END record ignored", s.truncated_bytes);
        s.warnings.push_back(s.stop_detail);
      }
      break;
    }
    if (!decode_data(raw, scratch, &why)) {
      const std::string what =
          fmt::format("record {} ({}): {}", index, format::to_string(raw.header.type), why);
      if (skip_damage(index, what)) {
        index = raw.header.index - 1;
        continue;
      }
      stop_at(Stop::Corrupt, fmt::format("{} at byte {}", what, off));
      break;
    }
    tally.add(scratch);
    off += raw.total;
  }
  tally.finish();
  if (s.skipped_records > 0 || s.skipped_bytes > 0) {
    s.stop_detail += fmt::format("; skipped {} damaged record{} ({} bytes)", s.skipped_records,
                                 s.skipped_records == 1 ? "" : "s", s.skipped_bytes);
    s.warnings.push_back(fmt::format("skipped {} damaged record{} ({} bytes) and read on: {}",
                                     s.skipped_records, s.skipped_records == 1 ? "" : "s", s.skipped_bytes,
                                     s.damage.front()));
  }
}

void Reader::Impl::apply_manifest(const std::string& text, const char* origin) {
  const nlohmann::json m = nlohmann::json::parse(text, nullptr, false);
  if (m.is_discarded() || !m.is_object()) {
    summary.warnings.push_back(fmt::format("{}: not a JSON object", origin));
    return;
  }
  auto str = [&](const char* key) {
    const auto it = m.find(key);
    return it != m.end() && it->is_string() ? it->get<std::string>() : std::string();
  };
  summary.rig_name = str("rig_name");
  summary.meta_json = "{}";
  summary.software_version = str("software_version");
  if (const auto it = m.find("meta"); it != m.end()) summary.meta_json = it->dump();
  if (summary.format_version == 0) {  // no valid BEGIN: the manifest says which version wrote the file
    if (const auto it = m.find("format_version"); it != m.end() && it->is_number_unsigned() &&
                                                  it->get<uint64_t>() >= 1 &&
                                                  it->get<uint64_t>() <= format::kFormatVersion)
      summary.format_version = it->get<uint32_t>();
  }
  if (summary.created_unix_ns == 0) {
    if (const auto it = m.find("created_unix_ns"); it != m.end() && it->is_number_integer())
      summary.created_unix_ns = it->get<int64_t>();
  }
}

void Reader::Impl::check_copies(const fs::path& dir, const nlohmann::json& manifest) {
  auto check = [&](const char* key, const char* name, bool* ok) {
    *ok = false;
    uint32_t want = 0;
    try {
      want = manifest.at("files").at(key).at("crc32c").get<uint32_t>();
    } catch (const std::exception&) {
      summary.warnings.push_back(fmt::format("the manifest has no checksum for {}", name));
      return;
    }
    std::string text;
    try {
      text = io::read_file(dir / name, name);
    } catch (const std::exception& e) {
      summary.warnings.push_back(e.what());
      return;
    }
    *ok = vc_crc32c(0, text.data(), text.size()) == want;
    if (!*ok) summary.warnings.push_back(fmt::format("{} does not match its checksum in the manifest", name));
  };
  check("rig_toml", io::kRigFile, &summary.rig_toml_ok);
  check("calibration", io::kCalibrationFile, &summary.calibration_ok);
}

void Reader::Impl::read_rig_nodes(const fs::path& dir) {
  try {
    const toml::table rig =
        toml::parse(io::read_file(dir / io::kRigFile, "rig.toml"), (dir / io::kRigFile).string());
    if (const toml::array* nodes = rig["nodes"].as_array())
      for (const toml::node& n : *nodes)
        if (const toml::table* t = n.as_table())
          summary.rig_node_ids.push_back((*t)["id"].value_or(std::string()));
  } catch (const std::exception&) {
    summary.rig_node_ids.clear();  // the names are a convenience; the ids in the records stand alone
  }
}

Reader::Reader(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {
  rewind();
}
Reader::Reader(Reader&&) noexcept = default;
Reader& Reader::operator=(Reader&&) noexcept = default;
Reader::~Reader() = default;

Reader Reader::open(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw std::runtime_error(fmt::format("{} is not a session folder (not a directory)", dir.string()));
  const fs::path records_path = dir / io::kRecordsFile;
  // O_NONBLOCK: a FIFO named records.vcr would otherwise block open() until a writer came.
  const int fd = ::open(records_path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
  if (fd < 0) {
    if (errno == ENOENT)
      throw std::runtime_error(
          fmt::format("{} is not a session folder (no {})", dir.string(), io::kRecordsFile));
    io::throw_errno("cannot open", records_path, errno);
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int err = errno;
    ::close(fd);
    io::throw_errno("cannot read", records_path, err);
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    throw std::runtime_error(fmt::format("cannot read {}: not a regular file", records_path.string()));
  }
  if (const int flags = ::fcntl(fd, F_GETFL); flags >= 0) (void)::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  auto impl = std::make_unique<Impl>();
  impl->src = Source::file(fd, static_cast<uint64_t>(st.st_size));
  impl->scan();

  // The manifest: session.json, else the copy in BEGIN.
  Summary& s = impl->summary;
  std::string text;
  try {
    text = io::read_file(dir / io::kManifestFile, "manifest");
  } catch (const std::exception& e) {
    s.warnings.push_back(e.what());
  }
  nlohmann::json manifest = nlohmann::json::parse(text, nullptr, false);
  if (!text.empty() && (manifest.is_discarded() || !manifest.is_object())) {
    s.warnings.push_back(fmt::format("{} is not a JSON object", io::kManifestFile));
    text.clear();
  }
  if (text.empty() && !impl->begin_manifest.empty()) {
    s.warnings.push_back("using the copy of the manifest in records.vcr");
    text = impl->begin_manifest;
    manifest = nlohmann::json::parse(text, nullptr, false);
  } else if (!text.empty() && !impl->begin_manifest.empty() && text != impl->begin_manifest) {
    s.warnings.push_back("session.json differs from its copy in records.vcr (edited after recording?)");
  }
  if (!text.empty()) {
    impl->apply_manifest(text, io::kManifestFile);
    impl->check_copies(dir, manifest);
  }
  impl->read_rig_nodes(dir);
  return Reader(std::move(impl));
}

Reader Reader::from_bytes(std::vector<uint8_t> records_vcr) {
  auto impl = std::make_unique<Impl>();
  impl->src = Source::memory(std::move(records_vcr));
  impl->scan();
  if (!impl->begin_manifest.empty()) impl->apply_manifest(impl->begin_manifest, "BEGIN manifest");
  return Reader(std::move(impl));
}

Reader::Summary Reader::summary() const {
  return impl_->summary;
}
const Reader::Summary& Reader::summary_ref() const {
  return impl_->summary;
}

bool Reader::next(Record& out) {
  Impl& s = *impl_;
  while (s.it_gap < s.gaps.size() && s.gaps[s.it_gap].from <= s.it_off) {  // damage skipped by the scan
    if (s.gaps[s.it_gap].from == s.it_off) {
      s.it_off = s.gaps[s.it_gap].to;
      s.it_index = s.gaps[s.it_gap].index;
    }
    ++s.it_gap;
  }
  if (s.it_off >= s.data_end) return false;
  RawRecord raw;
  std::string why;
  if (read_record(s.src, s.it_off, s.it_index, &raw, &why) != Step::Ok || !decode_data(raw, out, &why)) {
    // Validated by the scan in open(); failing now means the file changed under us. Stop here.
    s.it_off = s.data_end;
    return false;
  }
  s.it_off += raw.total;
  ++s.it_index;
  if (const auto* pose = std::get_if<PoseRecord>(&out); pose && !pose->joint_names.empty())
    s.joint_names = pose->joint_names;
  return true;
}

void Reader::rewind() {
  impl_->it_off = impl_->data_begin;
  impl_->it_index = impl_->first_index;
  impl_->it_gap = 0;
  impl_->joint_names.clear();
}

const std::vector<std::string>& Reader::joint_names() const {
  return impl_->joint_names;
}

double Reader::Summary::duration_s() const {
  if (frames < 2 || last_trigger_ns < first_trigger_ns) return 0.0;
  return static_cast<double>(last_trigger_ns - first_trigger_ns) / 1e9;
}

const char* to_string(Reader::Stop stop) {
  switch (stop) {
    case Reader::Stop::Closed:
      return "closed";
    case Reader::Stop::EndOfFile:
      return "cut";
    case Reader::Stop::TornTail:
      return "torn";
    case Reader::Stop::Corrupt:
      return "corrupt";
  }
  return "?";
}

}  // namespace vc::record
