// Subprocesses with their stdin, stdout and stderr over pipes and poll(), bounded in time and output.
#include "voxcap/deploy/remote.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/core.h>

#include <cerrno>
#include <chrono>
#include <cstring>

namespace vc::deploy {
namespace {

void close_fd(int& fd) {
  if (fd >= 0) ::close(fd);
  fd = -1;
}

std::string shell_words(const std::string& sudo, bool as_root) {
  return (as_root && !sudo.empty() ? sudo + " " : std::string()) + "sh -s";
}

}  // namespace

ProcessResult run_process(const std::vector<std::string>& argv, const std::string& input, double timeout_s) {
  ProcessResult r;
  int in[2] = {-1, -1}, out[2] = {-1, -1}, err[2] = {-1, -1};
  if (argv.empty() || ::pipe2(in, O_CLOEXEC) < 0 || ::pipe2(out, O_CLOEXEC) < 0 ||
      ::pipe2(err, O_CLOEXEC) < 0) {
    r.why = fmt::format("cannot start {}: {}", argv.empty() ? "" : argv[0], std::strerror(errno));
    for (int* p : {in, out, err}) close_fd(p[0]), close_fd(p[1]);
    return r;
  }
  std::vector<char*> args;
  args.reserve(argv.size() + 1);
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::setpgid(0, 0);  // its own group: a timeout kills ssh and whatever it started
    ::dup2(in[0], 0);
    ::dup2(out[1], 1);
    ::dup2(err[1], 2);
    ::execvp(args[0], args.data());
    const char msg[] = "exec failed\n";
    (void)!::write(2, msg, sizeof msg - 1);
    ::_exit(127);
  }
  close_fd(in[0]);
  close_fd(out[1]);
  close_fd(err[1]);
  if (pid < 0) {
    r.why = fmt::format("cannot start {}: {}", argv[0], std::strerror(errno));
    for (int* p : {in, out, err}) close_fd(p[0]), close_fd(p[1]);
    return r;
  }
  ::fcntl(in[1], F_SETFL, O_NONBLOCK);
  size_t written = 0;
  if (input.empty()) close_fd(in[1]);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  char buf[65536];
  while (out[0] >= 0 || err[0] >= 0) {
    const auto left = deadline - std::chrono::steady_clock::now();
    if (left <= std::chrono::steady_clock::duration::zero()) {
      r.timed_out = true;
      ::kill(-pid, SIGKILL);
      break;
    }
    pollfd fds[3] = {{out[0], POLLIN, 0}, {err[0], POLLIN, 0}, {in[1], POLLOUT, 0}};
    const int ms = static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(left).count()) + 1;
    if (::poll(fds, 3, ms) < 0) {
      if (errno == EINTR) continue;
      break;
    }
    for (int k = 0; k < 2; ++k) {
      int& fd = k == 0 ? out[0] : err[0];
      if (fd < 0 || !(fds[k].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const ssize_t n = ::read(fd, buf, sizeof buf);
      if (n <= 0) {
        if (n < 0 && errno == EINTR) continue;
        close_fd(fd);
        continue;
      }
      std::string& dst = k == 0 ? r.out : r.err;
      dst.append(buf,
                 std::min(static_cast<size_t>(n), kMaxOutputBytes - std::min(kMaxOutputBytes, dst.size())));
    }
    if (in[1] >= 0 && (fds[2].revents & (POLLOUT | POLLERR | POLLHUP))) {
      const ssize_t n = ::write(in[1], input.data() + written, input.size() - written);
      if (n > 0) written += static_cast<size_t>(n);
      if ((n < 0 && errno != EAGAIN && errno != EINTR) || written == input.size()) close_fd(in[1]);
    }
  }
  for (int* p : {in, out, err}) close_fd(p[0]), close_fd(p[1]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!r.timed_out && WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  if (r.timed_out) r.why = fmt::format("{} timed out after {} s", argv[0], timeout_s);
  return r;
}

std::vector<std::string> SshRemote::command(const Board& board, bool as_root) {
  const BoardSettings& s = board.settings;
  std::vector<std::string> a = {"ssh", "-T",
                                "-o",  "BatchMode=yes",
                                "-o",  "LogLevel=ERROR",
                                "-o",  fmt::format("ConnectTimeout={}", s.connect_timeout_s),
                                "-o",  "ServerAliveInterval=5",
                                "-o",  "ServerAliveCountMax=3",
                                "-o",  "StrictHostKeyChecking=" + s.host_key_checking,
                                "-p",  std::to_string(s.ssh_port)};
  if (!s.known_hosts.empty()) a.insert(a.end(), {"-o", "UserKnownHostsFile=" + s.known_hosts.string()});
  if (!s.identity.empty()) a.insert(a.end(), {"-i", s.identity.string(), "-o", "IdentitiesOnly=yes"});
  a.insert(a.end(), {s.ssh, "--", shell_words(s.sudo, as_root)});
  return a;
}

ProcessResult SshRemote::run(const Board& board, const std::string& script, bool as_root) {
  ProcessResult r = run_process(command(board, as_root), script, board.settings.step_timeout_s);
  if (r.exit_code == 255 && r.why.empty()) {  // ssh's own failure: unreachable, host key, authentication
    std::string e = r.err;
    while (!e.empty() && (e.back() == '\n' || e.back() == '\r')) e.pop_back();
    const size_t nl = e.rfind('\n');
    r.why = "ssh " + board.settings.ssh + ": " + (nl == std::string::npos ? e : e.substr(nl + 1));
  }
  return r;
}

ProcessResult LocalRemote::run(const Board& board, const std::string& script, bool as_root) {
  std::vector<std::string> argv;
  if (as_root && !board.settings.sudo.empty()) {
    std::string w;
    for (char c : board.settings.sudo + " ") {
      if (c == ' ') {
        if (!w.empty()) argv.push_back(w);
        w.clear();
      } else {
        w += c;
      }
    }
  }
  argv.insert(argv.end(), {"sh", "-s"});
  return run_process(argv, script, board.settings.step_timeout_s);
}

}  // namespace vc::deploy
