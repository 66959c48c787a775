// The session writer. Durability model:
//   - kill -9: every record is handed to the kernel by one write(2) on an O_APPEND descriptor before
//     append() returns, so a killed process loses nothing it appended; only a record whose write was
//     in progress can be missing or torn (SIGKILL may cut a large write short), and the reader drops
//     that tail.
//   - power loss: the page cache is lost, so only what flush() (fdatasync) covered is certain; the
//     rest may be missing, torn or zero-filled, and the reader again stops at the first bad record.
// Creation writes the copies and records.vcr (with BEGIN) first, syncs them, and publishes the
// manifest last with tmp + rename, so a session.json on disk always names complete files.
#include "voxcap/record/recorder.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <system_error>

#include <fmt/format.h>
#include <toml++/toml.h>
#include <nlohmann/json.hpp>

#include "io.hpp"
#include "voxcap/base/clock.hpp"
#include "voxcap/crc32c.h"
#include "voxcap/record/format.hpp"

#ifndef VOXCAP_VERSION
#define VOXCAP_VERSION "unknown"
#endif

namespace vc::record {
namespace fs = std::filesystem;

namespace {

// rig.toml's top-level `name`, else the file's stem (host/config/README.md: same default).
std::string rig_name_of(const fs::path& rig_toml, const std::string& text) {
  toml::table root;
  try {
    root = toml::parse(text, rig_toml.string());
  } catch (const toml::parse_error& e) {
    throw std::invalid_argument(fmt::format("rig config {} is not valid TOML: {} (line {})",
                                            rig_toml.string(), e.description(), e.source().begin.line));
  }
  if (const auto name = root["name"].value<std::string>(); name && !name->empty()) return *name;
  return rig_toml.stem().string();
}

nlohmann::json parse_meta(const std::string& meta) {
  if (meta.find_first_not_of(" \t\r\n") == std::string::npos) return nlohmann::json::object();
  nlohmann::json j = nlohmann::json::parse(meta, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object())
    throw std::invalid_argument("session meta must be a JSON object (or empty)");
  return j;
}

std::string hostname() {
  char buf[256] = {};
  if (::gethostname(buf, sizeof buf - 1) != 0) return "";
  return buf;
}

// Makes `dir` an existing empty directory; true when this call created it.
bool prepare_dir(const fs::path& dir) {
  std::error_code ec;
  const fs::file_status st = fs::status(dir, ec);
  if (fs::exists(st)) {
    if (!fs::is_directory(st))
      throw std::runtime_error(fmt::format("session folder {} exists and is not a directory", dir.string()));
    if (!fs::is_empty(dir, ec) || ec)
      throw std::runtime_error(fmt::format("session folder {} exists and is not empty", dir.string()));
    return false;
  }
  if (dir.has_parent_path()) {
    fs::create_directories(dir.parent_path(), ec);
    if (ec)
      throw std::runtime_error(
          fmt::format("cannot create folder {}: {}", dir.parent_path().string(), ec.message()));
  }
  if (::mkdir(dir.c_str(), 0755) != 0) io::throw_errno("cannot create session folder", dir, errno);
  return true;
}

}  // namespace

struct Recorder::Impl {
  fs::path dir;
  int fd = -1;
  mutable std::mutex mu;
  std::vector<uint8_t> buf;  // encode buffer: grows to the largest record, then reused
  uint64_t next_index = 0;   // record number of the next record
  uint64_t data_records = 0;
  uint64_t bytes = 0;
  bool closed = false;
  std::string broken;  // why this recorder can no longer write (empty: fine)

  ~Impl() {
    if (fd >= 0) ::close(fd);
  }

  // Writes buf as one record. On failure cuts the file back to the last complete record and throws.
  void write_record() {
    size_t written = 0;
    const int err = io::write_all(fd, buf.data(), buf.size(), &written);
    if (err == 0) {
      bytes += buf.size();
      ++next_index;
      return;
    }
    std::string msg =
        fmt::format("cannot append to {}: {}", (dir / io::kRecordsFile).string(), std::strerror(err));
    if (written > 0 && ::ftruncate(fd, static_cast<off_t>(bytes)) != 0) {
      broken = fmt::format("{}; cutting the partial record off failed too ({}), so the recorder stopped", msg,
                           std::strerror(errno));
      throw std::runtime_error(broken);
    }
    throw std::runtime_error(msg + " (record dropped; the session stays readable)");
  }

  template <typename R>
  void append(const R& r) {
    std::lock_guard lock(mu);
    if (closed) throw std::logic_error("Recorder: append after close()");
    if (!broken.empty()) throw std::runtime_error(broken);
    format::encode(r, next_index, buf);  // std::invalid_argument for a bad record: nothing written
    write_record();
    ++data_records;
  }
};

Recorder::Recorder(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Recorder::Recorder(Recorder&&) noexcept = default;
Recorder& Recorder::operator=(Recorder&&) noexcept = default;
Recorder::~Recorder() = default;

Recorder Recorder::create(const fs::path& dir, const fs::path& rig_toml, const fs::path& calibration_yaml,
                          const std::string& session_json_meta) {
  // Inputs first: nothing is created for a bad argument.
  const std::string rig_text = io::read_file(rig_toml, "rig config");
  const std::string calibration_text = io::read_file(calibration_yaml, "calibration");
  const nlohmann::json meta = parse_meta(session_json_meta);
  const std::string rig_name = rig_name_of(rig_toml, rig_text);

  const bool created_dir = prepare_dir(dir);
  std::vector<fs::path> created;  // removed again if creation fails half-way
  auto impl = std::make_unique<Impl>();
  impl->dir = dir;
  try {
    auto copy = [&](const char* name, const std::string& text) {
      io::write_new_file(dir / name, text);
      created.push_back(dir / name);
    };
    copy(io::kRigFile, rig_text);
    copy(io::kCalibrationFile, calibration_text);

    format::BeginRecord begin;
    begin.created_unix_ns = io::realtime_ns();
    begin.created_mono_ns = vc::monotonic_ns();
    auto file_entry = [](const char* name, const fs::path& source, const std::string& text) {
      std::error_code ec;
      fs::path abs = fs::absolute(source, ec);
      return nlohmann::json{{"path", name},
                            {"source", (ec ? source : abs).string()},
                            {"bytes", text.size()},
                            {"crc32c", vc_crc32c(0, text.data(), text.size())}};
    };
    const nlohmann::json manifest = {
        {"format", "voxcap-session"},
        {"format_version", format::kFormatVersion},
        {"created_utc", io::format_utc(begin.created_unix_ns)},
        {"created_unix_ns", begin.created_unix_ns},
        {"created_mono_ns", begin.created_mono_ns},
        {"software_version", VOXCAP_VERSION},
        {"hostname", hostname()},
        {"rig_name", rig_name},
        {"files",
         {{"records", io::kRecordsFile},
          {"rig_toml", file_entry(io::kRigFile, rig_toml, rig_text)},
          {"calibration", file_entry(io::kCalibrationFile, calibration_yaml, calibration_text)}}},
        {"meta", meta},
    };
    begin.manifest_json = manifest.dump(2) + "\n";

    const fs::path records_path = dir / io::kRecordsFile;
    impl->fd = ::open(records_path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_APPEND | O_CLOEXEC, 0644);
    if (impl->fd < 0) io::throw_errno("cannot create", records_path, errno);
    created.push_back(records_path);
    format::encode(begin, 0, impl->buf);
    impl->write_record();
    if (::fdatasync(impl->fd) != 0) io::throw_errno("cannot sync", records_path, errno);

    const fs::path tmp = dir / (std::string(io::kManifestFile) + ".tmp");
    io::write_new_file(tmp, begin.manifest_json);
    created.push_back(tmp);
    if (::rename(tmp.c_str(), (dir / io::kManifestFile).c_str()) != 0)
      io::throw_errno("cannot rename", tmp, errno);
    created.back() = dir / io::kManifestFile;
    io::sync_dir(dir);
    if (created_dir) io::sync_dir(dir.has_parent_path() ? dir.parent_path() : fs::path("."));
  } catch (...) {
    if (impl->fd >= 0) {
      ::close(impl->fd);
      impl->fd = -1;
    }
    std::error_code ec;
    for (auto it = created.rbegin(); it != created.rend(); ++it) fs::remove(*it, ec);
    if (created_dir) fs::remove(dir, ec);
    throw;
  }
  return Recorder(std::move(impl));
}

void Recorder::append(const FrameRecord& frame) {
  impl_->append(frame);
}
void Recorder::append(const FeatureRecord& features) {
  impl_->append(features);
}
void Recorder::append(const PoseRecord& pose) {
  impl_->append(pose);
}
void Recorder::append(const StatsRecord& stats) {
  impl_->append(stats);
}
void Recorder::append(const Features3DRecord& features3d) {
  impl_->append(features3d);
}

void Recorder::flush() {
  std::lock_guard lock(impl_->mu);
  if (impl_->closed) return;
  if (::fdatasync(impl_->fd) != 0) io::throw_errno("cannot sync", impl_->dir / io::kRecordsFile, errno);
}

void Recorder::close() {
  Impl& s = *impl_;
  std::lock_guard lock(s.mu);
  if (s.closed) return;
  s.closed = true;
  const fs::path path = s.dir / io::kRecordsFile;
  std::string error;
  if (s.broken.empty()) {
    try {
      format::encode(format::EndRecord{s.data_records, io::realtime_ns()}, s.next_index, s.buf);
      s.write_record();
    } catch (const std::exception& e) {
      error = e.what();
    }
  } else {
    error = s.broken;
  }
  if (error.empty() && ::fdatasync(s.fd) != 0)
    error = fmt::format("cannot sync {}: {}", path.string(), std::strerror(errno));
  if (::close(s.fd) != 0 && error.empty())
    error = fmt::format("cannot close {}: {}", path.string(), std::strerror(errno));
  s.fd = -1;
  std::vector<uint8_t>().swap(s.buf);
  if (!error.empty()) throw std::runtime_error(error);
}

uint64_t Recorder::records() const {
  std::lock_guard lock(impl_->mu);
  return impl_->data_records;
}

uint64_t Recorder::bytes() const {
  std::lock_guard lock(impl_->mu);
  return impl_->bytes;
}

const fs::path& Recorder::dir() const {
  return impl_->dir;
}

}  // namespace vc::record
