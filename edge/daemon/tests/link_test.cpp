// The edge's link against a fake host on 127.0.0.1: HELLO first, host messages delivered, heartbeats,
// reconnection after the host goes away, undecodable bytes drop the connection, a key rotation's two
// keys. Loops are bounded.
#include "link.h"
#include "log.h"
#include "voxcap/auth.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace {

struct FakeHost {
  int lfd = -1;
  uint16_t port = 0;
  FakeHost() {
    lfd = socket(AF_INET, SOCK_STREAM, 0);
    int one = 1;
    setsockopt(lfd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(bind(lfd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
    listen(lfd, 4);
    socklen_t len = sizeof(a);
    getsockname(lfd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
  }
  ~FakeHost() { close(lfd); }
  int accept_within(int ms) {
    pollfd p{lfd, POLLIN, 0};
    if (poll(&p, 1, ms) <= 0) return -1;
    return accept(lfd, nullptr, nullptr);
  }
};

// Reads messages from fd for up to ms, returning them decoded (types and seqs).
struct Received {
  std::vector<uint16_t> types;
  bool closed = false;
};
Received read_for(int fd, int ms, size_t stop_after = 1000) {
  Received r;
  vc_decoder* dec = nullptr;
  EXPECT_EQ(vc_decoder_new(0, &dec, nullptr, 0), 0);
  auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
  uint8_t buf[65536];
  while (std::chrono::steady_clock::now() < end && r.types.size() < stop_after) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 20) <= 0) continue;
    ssize_t n = recv(fd, buf, sizeof(buf), 0);
    if (n <= 0) {
      r.closed = true;
      break;
    }
    size_t used = 0;
    for (size_t off = 0; off < (size_t)n; off += used) {
      if (vc_decoder_feed(dec, buf + off, n - off, &used) < 0) break;
      vc_msg m;
      while (vc_decoder_next(dec, &m) > 0) r.types.push_back(m.hdr.type);
    }
  }
  vc_decoder_free(dec);
  return r;
}

std::vector<uint8_t> hello_bytes() {
  vc_hello h{};
  h.node_id = 4;
  h.camera_count = 1;
  h.cameras[0].width = 64;
  h.cameras[0].height = 48;
  std::vector<uint8_t> buf(256);
  size_t len = 0;
  vc_header hdr{};
  hdr.node_id = 4;
  EXPECT_EQ(vc_encode_hello(buf.data(), buf.size(), &len, &hdr, &h), 0);
  buf.resize(len);
  return buf;
}

struct Sink {
  std::mutex mu;
  std::vector<uint16_t> types;
  std::atomic<int> ups{0}, downs{0};
  static void on_message(void* u, const vc_msg* m) {
    auto* s = static_cast<Sink*>(u);
    std::lock_guard<std::mutex> g(s->mu);
    s->types.push_back(m->hdr.type);
  }
  static void on_connection(void* u, bool up) {
    (up ? static_cast<Sink*>(u)->ups : static_cast<Sink*>(u)->downs)++;
  }
  static uint32_t state(void*) { return VC_STATE_READY; }
};

vc_link* start_link(FakeHost& host, Sink& sink, int host_timeout_ms = 3000, const uint8_t* key = nullptr,
                    const uint8_t* next_key = nullptr) {
  vc_link_config cfg{};
  cfg.key = key;
  cfg.next_key = next_key;
  cfg.host = "127.0.0.1";
  cfg.port = host.port;
  cfg.node_id = 4;
  cfg.reconnect_min_ms = 20;
  cfg.reconnect_max_ms = 100;
  cfg.heartbeat_ms = 50;
  cfg.host_timeout_ms = host_timeout_ms;
  vc_link_callbacks cb{Sink::on_message, Sink::on_connection, Sink::state, &sink};
  auto hello = hello_bytes();
  vc_link* link = nullptr;
  char why[128] = "";
  EXPECT_EQ(vc_link_new(&cfg, &cb, hello.data(), hello.size(), &link, why, sizeof why), 0) << why;
  return link;
}

void send_start(int fd, uint64_t seq) {
  uint8_t buf[128];
  size_t len = 0;
  vc_header hdr{};
  hdr.seq = seq;
  ASSERT_EQ(vc_encode_start(buf, sizeof(buf), &len, &hdr), 0);
  ASSERT_EQ(send(fd, buf, len, MSG_NOSIGNAL), (ssize_t)len);
}

TEST(Link, HelloFirstThenHeartbeatsAndHostMessagesDelivered) {
  FakeHost host;
  Sink sink;
  vc_link* link = start_link(host, sink);
  int fd = host.accept_within(2000);
  ASSERT_GE(fd, 0);
  send_start(fd, 77);
  Received r = read_for(fd, 400);
  ASSERT_FALSE(r.types.empty());
  EXPECT_EQ(r.types[0], VC_MSG_HELLO);
  size_t hb = 0;
  for (auto t : r.types) hb += t == VC_MSG_HEARTBEAT;
  EXPECT_GE(hb, 2u);
  {
    std::lock_guard<std::mutex> g(sink.mu);
    ASSERT_EQ(sink.types.size(), 1u);
    EXPECT_EQ(sink.types[0], VC_MSG_START);
  }
  EXPECT_TRUE(vc_link_connected(link));
  vc_link_free(link);
  close(fd);
}

TEST(Link, QueuedMessagesReachTheHost) {
  FakeHost host;
  Sink sink;
  vc_link* link = start_link(host, sink);
  int fd = host.accept_within(2000);
  ASSERT_GE(fd, 0);
  for (int i = 0; i < 200 && !vc_link_connected(link); i++)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  uint8_t buf[128];
  size_t len = 0;
  vc_header hdr{};
  hdr.node_id = 4;
  ASSERT_EQ(vc_encode_stop(buf, sizeof(buf), &len, &hdr), 0);  // any message will do
  for (int i = 0; i < 5; i++) ASSERT_EQ(vc_link_send(link, buf, len), 0);
  Received r = read_for(fd, 300);
  size_t stops = 0;
  for (auto t : r.types) stops += t == VC_MSG_STOP;
  EXPECT_EQ(stops, 5u);
  vc_link_free(link);
  close(fd);
}

TEST(Link, ReconnectsAfterTheHostGoesAwayAndSaysHelloAgain) {
  FakeHost host;
  Sink sink;
  vc_link* link = start_link(host, sink);
  int fd = host.accept_within(2000);
  ASSERT_GE(fd, 0);
  read_for(fd, 100, 1);
  close(fd);  // the host goes away
  int fd2 = host.accept_within(3000);
  ASSERT_GE(fd2, 0) << "the link did not reconnect";
  Received r = read_for(fd2, 300, 1);
  ASSERT_FALSE(r.types.empty());
  EXPECT_EQ(r.types[0], VC_MSG_HELLO);
  vc_link_stats st;
  vc_link_get_stats(link, &st);
  EXPECT_GE(st.connects, 2u);
  vc_link_free(link);
  close(fd2);
}

TEST(Link, GarbageFromTheHostDropsTheConnection) {
  FakeHost host;
  Sink sink;
  vc_link* link = start_link(host, sink);
  int fd = host.accept_within(2000);
  ASSERT_GE(fd, 0);
  read_for(fd, 100, 1);
  const char junk[64] = "this is not the voxcap protocol, not at all......";
  send(fd, junk, sizeof(junk), MSG_NOSIGNAL);
  Received r = read_for(fd, 2000);
  EXPECT_TRUE(r.closed);
  vc_link_stats st;
  vc_link_get_stats(link, &st);
  EXPECT_GE(st.rejected, 1u);
  vc_link_free(link);
  close(fd);
}

TEST(Link, SilentHostIsDroppedAfterTheTimeout) {
  FakeHost host;
  Sink sink;
  vc_link* link = start_link(host, sink, 300);
  int fd = host.accept_within(2000);
  ASSERT_GE(fd, 0);
  Received r = read_for(fd, 2000);  // we never answer
  EXPECT_TRUE(r.closed);
  vc_link_free(link);
  close(fd);
}

TEST(Link, NewRefusesBadArgumentsAndSaysWhy) {
  vc_link_config cfg{};
  cfg.host = "127.0.0.1";
  cfg.port = 0;
  vc_link_callbacks cb{};
  auto hello = hello_bytes();
  vc_link* link = reinterpret_cast<vc_link*>(0x1);
  char why[128] = "";
  EXPECT_EQ(vc_link_new(&cfg, &cb, hello.data(), hello.size(), &link, why, sizeof why), -EINVAL);
  EXPECT_EQ(link, nullptr);
  EXPECT_STREQ(why, "link: no host address or port");
  cfg.port = 1;
  EXPECT_EQ(vc_link_new(&cfg, &cb, nullptr, 0, &link, why, sizeof why), -EINVAL);
  EXPECT_STREQ(why, "link: no HELLO");
  vc_link_free(nullptr);
}

// The link writes through the daemon's one logger (vc_log), on its own thread.
TEST(Link, RejectedBytesAreLoggedAsAWarning) {
  struct Lines {
    std::mutex mu;
    std::vector<std::pair<vc_log_level, std::string>> v;
    static void sink(void* u, vc_log_level level, const char* msg) {
      auto* l = static_cast<Lines*>(u);
      std::lock_guard<std::mutex> g(l->mu);
      l->v.emplace_back(level, msg);
    }
  } lines;
  vc_log_set_sink(Lines::sink, &lines);
  FakeHost host;
  Sink sink;
  vc_link* link = start_link(host, sink);
  int fd = host.accept_within(2000);
  ASSERT_GE(fd, 0);
  read_for(fd, 100, 1);
  const char junk[64] = "this is not the voxcap protocol, not at all......";
  send(fd, junk, sizeof(junk), MSG_NOSIGNAL);
  EXPECT_TRUE(read_for(fd, 2000).closed);
  vc_link_free(link);  // joins the link thread: no more lines after this
  close(fd);
  vc_log_set_sink(nullptr, nullptr);
  bool warned = false;
  for (const auto& [level, msg] : lines.v)
    if (level == VC_LOG_WARN && msg.rfind("link: rejected a message from the host", 0) == 0) warned = true;
  EXPECT_TRUE(warned);
}

TEST(Link, SendWhileDisconnectedIsCountedNotQueued) {
  FakeHost host;
  Sink sink;
  close(host.lfd);  // nobody listens
  host.lfd = socket(AF_INET, SOCK_STREAM, 0);
  vc_link* link = start_link(host, sink);
  uint8_t b[4] = {1, 2, 3, 4};
  EXPECT_EQ(vc_link_send(link, b, 4), -ENOTCONN);
  vc_link_stats st;
  vc_link_get_stats(link, &st);
  EXPECT_EQ(st.queue_dropped, 1u);
  vc_link_free(link);
}

using Key = std::array<uint8_t, VC_AUTH_KEY_SIZE>;

Key random_key() {
  Key k{};
  vc_auth_random(k.data(), k.size());
  return k;
}

// The host's side of the handshake on fd, proving `key`: takes HELLO and the node's challenge,
// answers, and reads the node's proof. True when the node proved `key` too (false: it proved another
// or closed without proving).
bool host_handshake(int fd, const Key& key) {
  vc_decoder* dec = nullptr;
  EXPECT_EQ(vc_decoder_new(0, &dec, nullptr, 0), 0);
  uint8_t nn[VC_AUTH_NONCE_SIZE] = {}, nh[VC_AUTH_NONCE_SIZE] = {};
  bool result = false, done = false;
  auto end = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  uint8_t buf[4096];
  while (!done && std::chrono::steady_clock::now() < end) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 20) <= 0) continue;
    ssize_t n = recv(fd, buf, sizeof(buf), 0);
    if (n <= 0) break;
    size_t used = 0;
    for (size_t off = 0; off < (size_t)n && !done; off += used) {
      if (vc_decoder_feed(dec, buf + off, n - off, &used) < 0) {
        done = true;
        break;
      }
      vc_msg m;
      while (!done && vc_decoder_next(dec, &m) > 0) {
        if (m.hdr.type != VC_MSG_AUTH) continue;
        if (m.u.auth.step == VC_AUTH_CHALLENGE) {
          std::memcpy(nn, m.u.auth.nonce, sizeof nn);
          vc_auth_random(nh, sizeof nh);
          vc_auth_msg r{};
          r.step = VC_AUTH_RESPONSE;
          std::memcpy(r.nonce, nh, sizeof nh);
          vc_auth_prove(r.proof, key.data(), VC_AUTH_ROLE_HOST, 4, nn, nh);
          uint8_t out[VC_PROTO_HEADER_SIZE + 128];
          size_t len = 0;
          vc_header hdr{};
          hdr.node_id = 4;
          EXPECT_EQ(vc_encode_auth(out, sizeof out, &len, &hdr, &r), 0);
          EXPECT_EQ(send(fd, out, len, MSG_NOSIGNAL), (ssize_t)len);
        } else if (m.u.auth.step == VC_AUTH_PROOF) {
          result = vc_auth_verify(m.u.auth.proof, key.data(), VC_AUTH_ROLE_NODE, 4, nn, nh);
          done = true;
        }
      }
    }
  }
  vc_decoder_free(dec);
  return result;
}

// A key rotation under way (host/deploy/README.md "Keys"): the link holds the rig key and the next
// one, joins a host that proves either and proves that same key back; a host with a third key is
// never obeyed.
TEST(Link, DuringARotationEitherKeyTheHostProvesIsTaken) {
  ASSERT_EQ(vc_auth_init(), 0);
  const Key old_key = random_key(), next_key = random_key(), stranger = random_key();
  for (const Key* host_key : {&old_key, &next_key}) {
    SCOPED_TRACE(host_key == &old_key ? "host on the old key" : "host on the next key");
    FakeHost host;
    Sink sink;
    vc_link* link = start_link(host, sink, 3000, old_key.data(), next_key.data());
    int fd = host.accept_within(2000);
    ASSERT_GE(fd, 0);
    EXPECT_TRUE(host_handshake(fd, *host_key)) << "the node did not prove the key the host proved";
    for (int i = 0; i < 100 && sink.ups.load() == 0; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_EQ(sink.ups.load(), 1);
    vc_link_free(link);
    close(fd);
  }
  FakeHost host;
  Sink sink;
  vc_link* link = start_link(host, sink, 3000, old_key.data(), next_key.data());
  int fd = host.accept_within(2000);
  ASSERT_GE(fd, 0);
  EXPECT_FALSE(host_handshake(fd, stranger));
  vc_link_stats st{};
  for (int i = 0; i < 100 && st.auth_failures == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    vc_link_get_stats(link, &st);
  }
  EXPECT_GE(st.auth_failures, 1u);
  EXPECT_EQ(sink.ups.load(), 0);
  vc_link_free(link);
  close(fd);
}

}  // namespace
