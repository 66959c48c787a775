// File helpers shared by the recorder and the reader (internal to vc_host_record). POSIX calls live
// here and in recorder.cpp / reader.cpp only; every failure becomes a std::runtime_error naming the path.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

namespace vc::record::io {

inline constexpr const char* kRecordsFile = "records.vcr";
inline constexpr const char* kManifestFile = "session.json";
inline constexpr const char* kRigFile = "rig.toml";
inline constexpr const char* kCalibrationFile = "calibration.yaml";
// The most read_file() takes (a manifest, a rig.toml or a calibration is a few KB).
inline constexpr size_t kMaxSideFileBytes = size_t{64} << 20;

// "<what> <path>: <strerror(err)>"
[[noreturn]] void throw_errno(const std::string& what, const std::filesystem::path& path, int err);

// Whole file as bytes; throws runtime_error("cannot read <what> <path>: ...").
std::string read_file(const std::filesystem::path& path, const char* what);

// write(2) until all of `n` bytes are written (EINTR and short writes retried). Returns 0 or the errno
// of the failing call; *written (may be NULL) is how many bytes made it.
int write_all(int fd, const void* data, size_t n, size_t* written);

// pread(2) until n bytes are read or EOF. Returns bytes read, or -errno.
long long pread_all(int fd, void* data, size_t n, uint64_t offset);

// Creates `path` (must not exist) with `data`, fsyncs it. Throws on error.
void write_new_file(const std::filesystem::path& path, const std::string& data);

// fsync of a directory, so entries created in it survive a power loss. Throws on error.
void sync_dir(const std::filesystem::path& dir);

int64_t realtime_ns();
// "2024-05-01T12:00:00.123Z" (UTC, milliseconds).
std::string format_utc(int64_t unix_ns);

}  // namespace vc::record::io
