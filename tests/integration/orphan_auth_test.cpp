// Orphans obey no one (issue #13): a keyed host process (a forked child running the host's keyed
// session server, proto/SPEC.md "Authentication") and a voxcap-edge started by the test with the
// rig key. Once the edge has proved the key, the host is killed with kill -9; the test then listens
// on the host's port as a foreigner without the key, takes the edge's reconnection and sends
// BACKGROUND and START (any command: the edge must not even decode it as one). The edge must not obey (no
// HEARTBEAT or ERROR answers them: it says nothing after its HELLO and AUTH challenge and drops the
// connection) and must log why. Loopback only, bounded loops.
#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "voxcap/auth.h"
#include "voxcap/proto.h"
#include "voxcap/session/server.hpp"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct AcceptAll : vc::session::Handler {
  std::string on_hello(vc::session::ConnId, const vc_msg&, const std::string&) override { return ""; }
  void on_message(vc::session::ConnId, const vc_msg&, uint64_t) override {}
  void on_disconnect(vc::session::ConnId, const std::string&) override {}
};

uint16_t free_tcp_port() {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    close(fd);
    return 0;
  }
  socklen_t l = sizeof a;
  getsockname(fd, reinterpret_cast<sockaddr*>(&a), &l);
  close(fd);
  return ntohs(a.sin_port);
}

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// The host process (a forked child; it never returns): a keyed server on port until it is killed.
[[noreturn]] void run_host(uint16_t port, const fs::path& key_file) {
  int null = open("/dev/null", O_WRONLY);
  dup2(null, 1);
  dup2(null, 2);
  vc::session::ServerOptions o;
  o.port = port;
  o.key.resize(VC_AUTH_KEY_SIZE);
  char why[512];
  if (vc_auth_init() < 0 || vc_key_load(key_file.c_str(), o.key.data(), why, sizeof why) < 0) _exit(3);
  AcceptAll h;
  vc::session::Server s(o, h, [](vc::log::Level, const std::string&) {});
  s.start();
  for (int i = 0; i < 600; i++) std::this_thread::sleep_for(std::chrono::milliseconds(100));  // killed first
  _exit(0);
}

TEST(OrphanAuth, EdgeObeysNoStrangerAfterItsHostIsKilled) {
  ASSERT_EQ(vc_auth_init(), 0);
  char tmp[] = "/tmp/voxcap-orphan-auth-XXXXXX";
  ASSERT_NE(mkdtemp(tmp), nullptr);
  const fs::path dir = tmp, key = dir / "rig.key", log = dir / "edge.log";
  char why[512];
  ASSERT_EQ(vc_key_write(key.c_str(), false, nullptr, why, sizeof why), 0) << why;
  const uint16_t port = free_tcp_port();

  // The host, in its own process.
  pid_t host = fork();
  ASSERT_GE(host, 0);
  if (host == 0) run_host(port, key);
  // The edge, started here (not by the host: nothing kills it with its host).
  const std::string port_s = std::to_string(port), tport = std::to_string(free_tcp_port());
  std::vector<std::string> args = {VOXCAP_EDGE_BINARY,
                                   "--node-id",
                                   "0",
                                   "--host",
                                   "127.0.0.1",
                                   "--port",
                                   port_s,
                                   "--trigger",
                                   "udp",
                                   "--trigger-port",
                                   tport,
                                   "--camera0",
                                   "sim",
                                   "--camera1",
                                   "sim",
                                   "--size",
                                   "160x120",
                                   "--verbosity",
                                   "1",
                                   "--key",
                                   key.string()};
  pid_t edge = fork();
  ASSERT_GE(edge, 0);
  if (edge == 0) {
    int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    dup2(fd, 1);
    dup2(fd, 2);
    std::vector<char*> argv;
    argv.reserve(args.size() + 1);
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  auto wait_log = [&](const std::string& what, int seconds) {
    auto end = Clock::now() + std::chrono::seconds(seconds);
    while (Clock::now() < end) {
      if (slurp(log).find(what) != std::string::npos) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  };
  EXPECT_TRUE(wait_log("proved the rig key", 30)) << slurp(log);

  kill(host, SIGKILL);
  int st = 0;
  waitpid(host, &st, 0);

  // The foreigner on the host's port, without the key.
  int lfd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  int one = 1;
  setsockopt(lfd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(bind(lfd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0) << std::strerror(errno);
  ASSERT_EQ(listen(lfd, 4), 0);
  pollfd p{lfd, POLLIN, 0};
  ASSERT_EQ(poll(&p, 1, 15000), 1) << "the orphan did not retry its host";
  int c = accept(lfd, nullptr, nullptr);
  ASSERT_GE(c, 0);
  // Its HELLO (offering the key) and AUTH challenge; then CONFIG and START from us.
  std::vector<uint8_t> in;
  std::vector<uint16_t> types;
  vc_decoder* dec = nullptr;
  ASSERT_EQ(vc_decoder_new(0, &dec, why, sizeof why), 0);
  auto read_for = [&](int ms) {
    auto end = Clock::now() + std::chrono::milliseconds(ms);
    bool closed = false;
    while (Clock::now() < end && !closed) {
      pollfd q{c, POLLIN, 0};
      if (poll(&q, 1, 20) <= 0) continue;
      uint8_t b[4096];
      ssize_t n = recv(c, b, sizeof b, 0);
      if (n <= 0) {
        closed = true;
        break;
      }
      size_t used = 0;
      for (size_t off = 0; off < static_cast<size_t>(n); off += used) {
        if (vc_decoder_feed(dec, b + off, static_cast<size_t>(n) - off, &used) < 0) break;
        vc_msg m;
        while (vc_decoder_next(dec, &m) == 1) types.push_back(m.hdr.type);
      }
    }
    return closed;
  };
  read_for(500);
  ASSERT_GE(types.size(), 2u);
  EXPECT_EQ(types[0], VC_MSG_HELLO);
  EXPECT_EQ(types[1], VC_MSG_AUTH);
  uint8_t buf[512];
  size_t len = 0;
  vc_header h{};
  ASSERT_EQ(vc_encode_start(buf, sizeof buf, &len, &h), 0);
  std::vector<uint8_t> attack(buf, buf + len);
  vc_background bg{};
  bg.frame_count = 5;
  ASSERT_EQ(vc_encode_background(buf, sizeof buf, &len, &h, &bg), 0);
  attack.insert(attack.begin(), buf, buf + len);
  ASSERT_EQ(send(c, attack.data(), attack.size(), MSG_NOSIGNAL), static_cast<ssize_t>(attack.size()));
  const bool closed = read_for(5000);
  EXPECT_TRUE(closed) << "the edge kept a connection to a peer that did not prove the key";
  EXPECT_EQ(types.size(), 2u) << "the edge answered a stranger's commands";
  EXPECT_TRUE(wait_log("did not prove the rig key", 5)) << slurp(log);
  vc_decoder_free(dec);
  close(c);
  close(lfd);
  kill(edge, SIGKILL);
  waitpid(edge, &st, 0);
  fs::remove_all(dir);
}

}  // namespace
