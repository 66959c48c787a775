#include "io.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <stdexcept>

#include <fmt/format.h>

namespace vc::record::io {

void throw_errno(const std::string& what, const std::filesystem::path& path, int err) {
  throw std::runtime_error(fmt::format("{} {}: {}", what, path.string(), std::strerror(err)));
}

std::string read_file(const std::filesystem::path& path, const char* what) {
  // O_NONBLOCK then fstat: a FIFO (or a device) in a session folder is refused, never waited on.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
  if (fd < 0) throw_errno(fmt::format("cannot read {}", what), path, errno);
  std::string data;
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    const int err = S_ISDIR(st.st_mode) ? EISDIR : EINVAL;
    ::close(fd);
    if (err == EINVAL)
      throw std::runtime_error(fmt::format("cannot read {} {}: not a regular file", what, path.string()));
    throw_errno(fmt::format("cannot read {}", what), path, err);
  }
  if (static_cast<uint64_t>(st.st_size) > kMaxSideFileBytes) {
    ::close(fd);
    throw std::runtime_error(
        fmt::format("cannot read {} {}: larger than {} bytes", what, path.string(), kMaxSideFileBytes));
  }
  if (const int flags = ::fcntl(fd, F_GETFL); flags >= 0) (void)::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  char chunk[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, chunk, sizeof chunk);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      throw_errno(fmt::format("cannot read {}", what), path, err);
    }
    if (n == 0) break;
    if (data.size() + static_cast<size_t>(n) > kMaxSideFileBytes) {  // it grew while we read
      ::close(fd);
      throw std::runtime_error(
          fmt::format("cannot read {} {}: larger than {} bytes", what, path.string(), kMaxSideFileBytes));
    }
    data.append(chunk, static_cast<size_t>(n));
  }
  ::close(fd);
  return data;
}

int write_all(int fd, const void* data, size_t n, size_t* written) {
  const auto* p = static_cast<const uint8_t*>(data);
  size_t done = 0;
  int err = 0;
  while (done < n) {
    const ssize_t w = ::write(fd, p + done, n - done);
    if (w < 0) {
      if (errno == EINTR) continue;
      err = errno;
      break;
    }
    if (w == 0) {
      err = EIO;
      break;
    }
    done += static_cast<size_t>(w);
  }
  if (written) *written = done;
  return err;
}

long long pread_all(int fd, void* data, size_t n, uint64_t offset) {
  auto* p = static_cast<uint8_t*>(data);
  size_t done = 0;
  while (done < n) {
    const ssize_t r = ::pread(fd, p + done, n - done, static_cast<off_t>(offset + done));
    if (r < 0) {
      if (errno == EINTR) continue;
      return -errno;
    }
    if (r == 0) break;
    done += static_cast<size_t>(r);
  }
  return static_cast<long long>(done);
}

void write_new_file(const std::filesystem::path& path, const std::string& data) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) throw_errno("cannot create", path, errno);
  int err = write_all(fd, data.data(), data.size(), nullptr);
  if (err == 0 && ::fsync(fd) != 0) err = errno;
  if (::close(fd) != 0 && err == 0) err = errno;
  if (err != 0) throw_errno("cannot write", path, err);
}

void sync_dir(const std::filesystem::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) throw_errno("cannot open directory", dir, errno);
  int err = 0;
  // Some file systems (tmpfs on old kernels, some FUSE) refuse fsync on directories: nothing to do there.
  if (::fsync(fd) != 0 && errno != EINVAL && errno != EROFS) err = errno;
  ::close(fd);
  if (err != 0) throw_errno("cannot sync directory", dir, err);
}

int64_t realtime_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

std::string format_utc(int64_t unix_ns) {
  int64_t sec = unix_ns / 1000000000;
  int64_t ns = unix_ns % 1000000000;
  if (ns < 0) {
    ns += 1000000000;
    --sec;
  }
  const time_t t = static_cast<time_t>(sec);
  tm utc{};
  if (!::gmtime_r(&t, &utc)) return "?";
  return fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}.{:03}Z", utc.tm_year + 1900, utc.tm_mon + 1,
                     utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec, ns / 1000000);
}

}  // namespace vc::record::io
