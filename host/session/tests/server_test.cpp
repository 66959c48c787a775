// The session server against real client sockets on 127.0.0.1. Loops are bounded in time.
#include "voxcap/session/server.hpp"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <thread>
#include <vector>

#include "voxcap/crc32c.h"

namespace vc::session {
namespace {

struct Recorder : Handler {
  std::mutex mu;
  std::condition_variable cv;
  std::vector<uint16_t> hellos;
  std::vector<uint16_t> types;
  std::vector<std::string> disconnects;
  std::string reject_reason;
  std::string on_hello(ConnId, const vc_msg& m, const std::string&) override {
    std::lock_guard<std::mutex> g(mu);
    hellos.push_back(m.u.hello.node_id);
    cv.notify_all();
    return m.u.hello.node_id == 99 ? "node 99 is not in the rig" : "";
  }
  void on_message(ConnId, const vc_msg& m, uint64_t) override {
    std::lock_guard<std::mutex> g(mu);
    types.push_back(m.hdr.type);
    cv.notify_all();
  }
  void on_disconnect(ConnId, const std::string& reason) override {
    std::lock_guard<std::mutex> g(mu);
    disconnects.push_back(reason);
    cv.notify_all();
  }
  template <typename Pred>
  bool wait(Pred p, int ms = 3000) {
    std::unique_lock<std::mutex> l(mu);
    return cv.wait_for(l, std::chrono::milliseconds(ms), p);
  }
};

int connect_to(uint16_t port) {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  EXPECT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
  return fd;
}

void send_hello(int fd, uint16_t node) {
  vc_hello h{};
  h.node_id = node;
  h.camera_count = 2;
  h.cameras[0].width = h.cameras[1].width = 64;
  h.cameras[0].height = h.cameras[1].height = 48;
  uint8_t buf[256];
  size_t len = 0;
  vc_header hdr{};
  hdr.node_id = node;
  ASSERT_EQ(vc_encode_hello(buf, sizeof(buf), &len, &hdr, &h), 0);
  ASSERT_EQ(::send(fd, buf, len, MSG_NOSIGNAL), (ssize_t)len);
}

void send_heartbeat(int fd, uint16_t node) {
  uint8_t buf[128];
  size_t len = 0;
  vc_header hdr{};
  hdr.node_id = node;
  vc_heartbeat hb{1, VC_STATE_READY};
  ASSERT_EQ(vc_encode_heartbeat(buf, sizeof(buf), &len, &hdr, &hb), 0);
  // Byte by byte: the server must reassemble arbitrary chunking.
  for (size_t i = 0; i < len; i++) ASSERT_EQ(::send(fd, buf + i, 1, MSG_NOSIGNAL), 1);
}

// Reads until the peer closes or ms pass; returns true if it closed.
bool closed_within(int fd, int ms) {
  auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
  uint8_t b[4096];
  while (std::chrono::steady_clock::now() < end) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 20) <= 0) continue;
    ssize_t n = recv(fd, b, sizeof(b), 0);
    if (n <= 0) return true;
  }
  return false;
}

ServerOptions opts() {
  ServerOptions o;
  o.port = 0;
  o.heartbeat_interval_ms = 50;
  o.heartbeat_timeout_ms = 400;
  o.hello_timeout_ms = 400;
  return o;
}

TEST(SessionServer, HelloThenMessagesReachTheHandler) {
  Recorder h;
  Server s(opts(), h);
  s.start();
  int fd = connect_to(s.port());
  send_hello(fd, 3);
  send_heartbeat(fd, 3);
  ASSERT_TRUE(h.wait([&] { return !h.types.empty(); }));
  EXPECT_EQ(h.hellos, std::vector<uint16_t>{3});
  EXPECT_EQ(h.types[0], VC_MSG_HEARTBEAT);
  auto conns = s.connections();
  ASSERT_EQ(conns.size(), 1u);
  EXPECT_EQ(conns[0].node_id, 3);
  close(fd);
  ASSERT_TRUE(h.wait([&] { return !h.disconnects.empty(); }));
  s.stop();
}

TEST(SessionServer, RejectedHelloClosesTheConnection) {
  Recorder h;
  Server s(opts(), h);
  s.start();
  int fd = connect_to(s.port());
  send_hello(fd, 99);
  EXPECT_TRUE(closed_within(fd, 2000));
  EXPECT_EQ(s.stats().hello_rejected, 1u);
  close(fd);
  s.stop();
}

TEST(SessionServer, GarbageDropsOnlyThatConnection) {
  Recorder h;
  Server s(opts(), h);
  s.start();
  int good = connect_to(s.port());
  int bad = connect_to(s.port());
  send_hello(good, 1);
  send_hello(bad, 2);
  ASSERT_TRUE(h.wait([&] { return h.hellos.size() == 2; }));
  const char junk[80] = "garbage garbage garbage garbage garbage garbage garbage garbage";
  ::send(bad, junk, sizeof(junk), MSG_NOSIGNAL);
  EXPECT_TRUE(closed_within(bad, 2000));
  ASSERT_TRUE(h.wait([&] { return h.disconnects.size() == 1; }));
  EXPECT_NE(h.disconnects[0].find("VC_PROTO_EMAGIC"), std::string::npos) << h.disconnects[0];
  // The good node goes on.
  send_heartbeat(good, 1);
  ASSERT_TRUE(h.wait([&] { return !h.types.empty(); }));
  EXPECT_EQ(s.connections().size(), 1u);
  EXPECT_EQ(s.stats().decode_drops, 1u);
  close(good);
  close(bad);
  s.stop();
}

TEST(SessionServer, FirstMessageMustBeHello) {
  Recorder h;
  Server s(opts(), h);
  s.start();
  int fd = connect_to(s.port());
  send_heartbeat(fd, 1);
  EXPECT_TRUE(closed_within(fd, 2000));
  EXPECT_TRUE(h.hellos.empty());
  close(fd);
  s.stop();
}

TEST(SessionServer, SilentNodeTimesOutAndServerSendsHeartbeats) {
  Recorder h;
  Server s(opts(), h);
  s.start();
  int fd = connect_to(s.port());
  send_hello(fd, 5);
  // We read the server's heartbeats but say nothing: dropped after ~400 ms.
  vc_decoder* dec = nullptr;
  ASSERT_EQ(vc_decoder_new(0, &dec, nullptr, 0), 0);
  int heartbeats = 0;
  bool closed = false;
  auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(2000);
  uint8_t b[4096];
  while (!closed && std::chrono::steady_clock::now() < end) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 20) <= 0) continue;
    ssize_t n = recv(fd, b, sizeof(b), 0);
    if (n <= 0) {
      closed = true;
      break;
    }
    size_t used = 0;
    for (size_t off = 0; off < (size_t)n; off += used) {
      vc_decoder_feed(dec, b + off, n - off, &used);
      vc_msg m;
      while (vc_decoder_next(dec, &m) > 0) heartbeats += m.hdr.type == VC_MSG_HEARTBEAT;
    }
  }
  vc_decoder_free(dec);
  EXPECT_TRUE(closed);
  EXPECT_GE(heartbeats, 3);
  ASSERT_TRUE(h.wait([&] { return !h.disconnects.empty(); }));
  EXPECT_NE(h.disconnects[0].find("heartbeat timeout"), std::string::npos);
  close(fd);
  s.stop();
}

TEST(SessionServer, SendReachesTheEdge) {
  Recorder h;
  Server s(opts(), h);
  s.start();
  int fd = connect_to(s.port());
  send_hello(fd, 2);
  ASSERT_TRUE(h.wait([&] { return !h.hellos.empty(); }));
  auto conns = s.connections();
  ASSERT_EQ(conns.size(), 1u);
  uint8_t buf[128];
  size_t len = 0;
  vc_header hdr{};
  hdr.seq = 1234;
  ASSERT_EQ(vc_encode_start(buf, sizeof(buf), &len, &hdr), 0);
  EXPECT_TRUE(s.send(conns[0].id, buf, len));
  EXPECT_TRUE(s.drain(2000)) << "the queued START was written";
  vc_decoder* dec = nullptr;
  ASSERT_EQ(vc_decoder_new(0, &dec, nullptr, 0), 0);
  bool got = false;
  auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(2000);
  uint8_t b[4096];
  while (!got && std::chrono::steady_clock::now() < end) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 20) <= 0) continue;
    ssize_t n = recv(fd, b, sizeof(b), 0);
    if (n <= 0) break;
    size_t used = 0;
    for (size_t off = 0; off < (size_t)n; off += used) {
      vc_decoder_feed(dec, b + off, n - off, &used);
      vc_msg m;
      while (vc_decoder_next(dec, &m) > 0)
        if (m.hdr.type == VC_MSG_START && m.hdr.seq == 1234) got = true;
    }
  }
  vc_decoder_free(dec);
  EXPECT_TRUE(got);
  close(fd);
  s.stop();
}

// Issue #13, "memory before HELLO is unbounded": a stranger's first message that declares 8 MiB is
// dropped after its header, and strangers beyond max_prehello_connections evict the oldest, while a
// node that said HELLO keeps its connection and its messages through all of it.
TEST(SessionServer, StrangersBeforeHelloAreBoundedInCountAndBytes) {
  Recorder h;
  ServerOptions o = opts();
  o.hello_timeout_ms = 5000;  // the bounds below act, not the timeout
  o.heartbeat_timeout_ms = 5000;
  o.max_prehello_connections = 4;
  Server s(o, h);
  s.start();
  int node = connect_to(s.port());
  send_hello(node, 3);
  ASSERT_TRUE(h.wait([&] { return h.hellos.size() == 1; }));
  // One stranger declaring an 8 MiB message, then sending 1 MiB of it.
  int big = connect_to(s.port());
  uint8_t hdr[VC_PROTO_HEADER_SIZE];
  {
    std::vector<uint8_t> buf(VC_PROTO_HEADER_SIZE + 16);
    size_t len = 0;
    vc_header hh{};
    vc_background b{5};
    ASSERT_EQ(vc_encode_background(buf.data(), buf.size(), &len, &hh, &b), 0);
    std::memcpy(hdr, buf.data(), sizeof hdr);
    const uint32_t plen = VC_PROTO_MAX_PAYLOAD;
    std::memcpy(&hdr[12], &plen, 4);
    const uint32_t hc = vc_crc32c(0, hdr, 36);
    std::memcpy(&hdr[36], &hc, 4);
  }
  ASSERT_EQ(::send(big, hdr, sizeof hdr, MSG_NOSIGNAL), (ssize_t)sizeof hdr);
  std::vector<uint8_t> junk(1 << 16, 0x5a);
  for (int i = 0; i < 16; i++)
    if (::send(big, junk.data(), junk.size(), MSG_NOSIGNAL | MSG_DONTWAIT) < 0) break;
  EXPECT_TRUE(closed_within(big, 3000)) << "oversize first message: dropped";
  close(big);
  // Ten silent strangers: at most four stay open, the oldest go first.
  std::vector<int> strangers;
  for (int i = 0; i < 10; i++) {
    strangers.push_back(connect_to(s.port()));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));  // accepted in this order
  }
  for (int i = 0; i < 6; i++) EXPECT_TRUE(closed_within(strangers[static_cast<size_t>(i)], 3000)) << i;
  for (int i = 6; i < 10; i++) EXPECT_FALSE(closed_within(strangers[static_cast<size_t>(i)], 100)) << i;
  ServerStats st = s.stats();
  EXPECT_EQ(st.prehello_evicted, 6u);
  EXPECT_GE(st.decode_drops, 1u);
  // The node was never touched.
  send_heartbeat(node, 3);
  ASSERT_TRUE(h.wait([&] { return !h.types.empty(); }));
  EXPECT_TRUE(h.disconnects.empty());
  for (int fd : strangers) close(fd);
  close(node);
  s.stop();
}

}  // namespace
}  // namespace vc::session
