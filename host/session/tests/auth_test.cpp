// The session server with a rig key (protocol 2.3) against a test client on 127.0.0.1 that plays the
// node with the proto library: the challenge-response both ways, MACs both ways, and what a stranger
// gets (no key, a wrong key, a reflected proof, forged, replayed and reordered messages).
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <string>
#include <vector>

#include "voxcap/auth.h"
#include "voxcap/session/server.hpp"

namespace vc::session {
namespace {

using Key = std::array<uint8_t, VC_AUTH_KEY_SIZE>;

struct Recorder : Handler {
  std::mutex mu;
  std::condition_variable cv;
  std::vector<uint16_t> hellos;
  std::vector<uint64_t> heartbeat_times;
  std::string on_hello(ConnId, const vc_msg& m, const std::string&) override {
    std::lock_guard<std::mutex> g(mu);
    hellos.push_back(m.u.hello.node_id);
    cv.notify_all();
    return "";
  }
  void on_message(ConnId, const vc_msg& m, uint64_t) override {
    std::lock_guard<std::mutex> g(mu);
    if (m.hdr.type == VC_MSG_HEARTBEAT) heartbeat_times.push_back(m.u.heartbeat.sender_time_ns);
    cv.notify_all();
  }
  void on_disconnect(ConnId, const std::string&) override {}
  std::vector<std::pair<uint16_t, int>> mac_rejected;  // (node, code) as on_mac_rejected told
  void on_mac_rejected(ConnId, uint16_t node_id, int code) override {
    std::lock_guard<std::mutex> g(mu);
    mac_rejected.emplace_back(node_id, code);
    cv.notify_all();
  }
  template <typename Pred>
  bool wait(Pred p, int ms = 3000) {
    std::unique_lock<std::mutex> l(mu);
    return cv.wait_for(l, std::chrono::milliseconds(ms), p);
  }
};

Key random_key() {
  Key k{};
  vc_auth_random(k.data(), k.size());
  return k;
}

// The node's side, written from SPEC.md with the proto library only.
struct Client {
  int fd = -1;
  uint16_t node = 2;
  vc_decoder* dec = nullptr;
  vc_mac tx{}, rx{};
  uint8_t nn[VC_AUTH_NONCE_SIZE] = {}, nh[VC_AUTH_NONCE_SIZE] = {};
  std::vector<std::vector<uint8_t>> sent;  // sealed messages, for replays

  explicit Client(uint16_t port) {
    fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
    char why[64];
    EXPECT_EQ(vc_decoder_new(0, &dec, why, sizeof why), 0);
  }
  ~Client() {
    vc_decoder_free(dec);
    close(fd);
  }
  void raw(const uint8_t* b, size_t n) { ASSERT_EQ(::send(fd, b, n, MSG_NOSIGNAL), static_cast<ssize_t>(n)); }
  void hello(bool offer_key) {
    vc_hello h{};
    h.node_id = node;
    h.capabilities = VC_CAP_HULL | (offer_key ? VC_CAP_AUTH : 0);
    h.camera_count = 1;
    h.cameras[0].width = 64;
    h.cameras[0].height = 48;
    uint8_t buf[256];
    size_t len = 0;
    vc_header hdr{};
    hdr.node_id = node;
    ASSERT_EQ(vc_encode_hello(buf, sizeof buf, &len, &hdr, &h), 0);
    raw(buf, len);
  }
  void auth(uint16_t step, const uint8_t* nonce, const uint8_t* proof) {
    vc_auth_msg a{};
    a.step = step;
    if (nonce) std::memcpy(a.nonce, nonce, 32);
    if (proof) std::memcpy(a.proof, proof, 32);
    uint8_t buf[256];
    size_t len = 0;
    vc_header hdr{};
    hdr.node_id = node;
    ASSERT_EQ(vc_encode_auth(buf, sizeof buf, &len, &hdr, &a), 0);
    raw(buf, len);
  }
  // The next message from the host (skipping nothing), or false after ms / on close.
  bool next(vc_msg* m, int* rc_out, int ms = 2000) {
    auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
    for (;;) {
      int rc = vc_decoder_next(dec, m);
      if (rc != 0) {
        *rc_out = rc;
        return true;
      }
      if (std::chrono::steady_clock::now() > end) return false;
      pollfd p{fd, POLLIN, 0};
      if (poll(&p, 1, 20) <= 0) continue;
      uint8_t b[4096];
      ssize_t n = recv(fd, b, sizeof b, 0);
      if (n <= 0) return false;
      size_t used = 0;
      for (size_t off = 0; off < static_cast<size_t>(n); off += used)
        EXPECT_EQ(vc_decoder_feed(dec, b + off, static_cast<size_t>(n) - off, &used), 0);
    }
  }
  // HELLO, challenge, the host's response checked, our proof; afterwards MACs both ways.
  bool handshake(const Key& key) {
    hello(true);
    vc_auth_random(nn, sizeof nn);
    auth(VC_AUTH_CHALLENGE, nn, nullptr);
    vc_msg m{};
    int rc = 0;
    if (!next(&m, &rc) || rc != 1 || m.hdr.type != VC_MSG_AUTH || m.u.auth.step != VC_AUTH_RESPONSE)
      return false;
    std::memcpy(nh, m.u.auth.nonce, sizeof nh);
    if (!vc_auth_verify(m.u.auth.proof, key.data(), VC_AUTH_ROLE_HOST, node, nn, nh)) return false;
    uint8_t proof[32];
    vc_auth_prove(proof, key.data(), VC_AUTH_ROLE_NODE, node, nn, nh);
    auth(VC_AUTH_PROOF, nullptr, proof);
    vc_auth_session(key.data(), node, nn, nh, &tx, &rx);
    vc_decoder_set_mac(dec, &rx);
    return true;
  }
  std::vector<uint8_t> heartbeat(vc_mac* mac, uint64_t t) {
    std::vector<uint8_t> b(VC_PROTO_HEADER_SIZE + 12 + VC_AUTH_TRAILER_SIZE);
    size_t len = 0, sealed = 0;
    vc_header hdr{};
    hdr.node_id = node;
    vc_heartbeat hb{t, VC_STATE_IDLE};
    EXPECT_EQ(vc_encode_heartbeat(b.data(), b.size(), &len, &hdr, &hb), 0);
    if (!mac) {
      b.resize(len);
      return b;
    }
    EXPECT_EQ(vc_mac_seal(mac, b.data(), len, b.size(), &sealed), 0);
    b.resize(sealed);
    return b;
  }
  bool closed_within(int ms) {
    auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
    uint8_t b[4096];
    while (std::chrono::steady_clock::now() < end) {
      pollfd p{fd, POLLIN, 0};
      if (poll(&p, 1, 20) <= 0) continue;
      if (recv(fd, b, sizeof b, 0) <= 0) return true;
    }
    return false;
  }
};

ServerOptions keyed(const Key& key) {
  ServerOptions o;
  o.port = 0;
  o.heartbeat_interval_ms = 50;
  o.heartbeat_timeout_ms = 1000;
  o.hello_timeout_ms = 1000;
  o.key.assign(key.begin(), key.end());
  return o;
}

struct SessionAuth : ::testing::Test {
  void SetUp() override { ASSERT_EQ(vc_auth_init(), 0); }
};

TEST_F(SessionAuth, KeyedNodeProvesTheKeyAndMessagesCarryMacsBothWays) {
  Key key = random_key();
  Recorder h;
  Server s(keyed(key), h);
  s.start();
  Client c(s.port());
  ASSERT_TRUE(c.handshake(key));
  ASSERT_TRUE(h.wait([&] { return h.hellos.size() == 1; }));
  for (uint64_t t = 1; t <= 3; t++) {
    auto b = c.heartbeat(&c.tx, t);
    c.raw(b.data(), b.size());
  }
  ASSERT_TRUE(h.wait([&] { return h.heartbeat_times.size() == 3; }));
  EXPECT_EQ(h.heartbeat_times, (std::vector<uint64_t>{1, 2, 3}));
  // The host's heartbeats verify with the host->node key, in order.
  for (int i = 0; i < 3; i++) {
    vc_msg m{};
    int rc = 0;
    ASSERT_TRUE(c.next(&m, &rc));
    EXPECT_EQ(rc, 1) << vc_proto_error_name(rc);
    EXPECT_EQ(m.hdr.type, VC_MSG_HEARTBEAT);
    EXPECT_TRUE(m.hdr.flags & VC_FLAG_MAC);
  }
  auto conns = s.connections();
  ASSERT_EQ(conns.size(), 1u);
  EXPECT_TRUE(conns[0].authenticated);
  EXPECT_TRUE(s.authenticated(conns[0].id));
  s.stop();
}

TEST_F(SessionAuth, ForgedReplayedAndReorderedMessagesAreDroppedCountedAndEndTheConnection) {
  Key key = random_key();
  Recorder h;
  Server s(keyed(key), h);
  s.start();
  Client c(s.port());
  ASSERT_TRUE(c.handshake(key));
  auto first = c.heartbeat(&c.tx, 1);
  c.raw(first.data(), first.size());
  ASSERT_TRUE(h.wait([&] { return h.heartbeat_times.size() == 1; }));
  // Forged: no MAC, and a MAC with a stranger's key.
  auto plain = c.heartbeat(nullptr, 100);
  c.raw(plain.data(), plain.size());
  vc_mac stranger{};
  vc_auth_random(stranger.key, sizeof stranger.key);
  auto forged = c.heartbeat(&stranger, 101);
  c.raw(forged.data(), forged.size());
  // Replayed: the first message again.
  c.raw(first.data(), first.size());
  // Reordered: the third before the second.
  auto second = c.heartbeat(&c.tx, 2), third = c.heartbeat(&c.tx, 3);
  c.raw(third.data(), third.size());
  c.raw(second.data(), second.size());
  ASSERT_TRUE(h.wait([&] { return h.heartbeat_times.size() == 2; }));
  auto conns = s.connections();
  ASSERT_EQ(conns.size(), 1u);
  EXPECT_EQ(conns[0].forged, 2u);
  EXPECT_EQ(conns[0].replayed, 1u);
  EXPECT_EQ(conns[0].reordered, 1u);
  EXPECT_EQ(h.heartbeat_times, (std::vector<uint64_t>{1, 2}));  // only the real ones, in order
  // Each drop is the node's, by reason, for the handler's per-node counts (NodeReport::mac_rejected),
  // and in the server's totals; none was a stranger's.
  ASSERT_TRUE(h.wait([&] { return h.mac_rejected.size() == 4; }));
  EXPECT_EQ(h.mac_rejected,
            (std::vector<std::pair<uint16_t, int>>{
                {2, VC_PROTO_EMAC}, {2, VC_PROTO_EMAC}, {2, VC_PROTO_EREPLAY}, {2, VC_PROTO_EORDER}}));
  const ServerStats st = s.stats();
  EXPECT_EQ(st.mac_forged, 2u);
  EXPECT_EQ(st.mac_replayed, 1u);
  EXPECT_EQ(st.mac_reordered, 1u);
  EXPECT_EQ(st.mac_unidentified, 0u);
  EXPECT_EQ(st.mac_rejected, 4u);
  // The real third one still passes after its reordered copy was dropped.
  c.raw(third.data(), third.size());
  ASSERT_TRUE(h.wait([&] { return h.heartbeat_times.size() == 3; }));
  // Enough failures close the connection.
  for (int i = 0; i < VC_AUTH_MAX_REJECTS; i++) c.raw(plain.data(), plain.size());
  EXPECT_TRUE(c.closed_within(2000));
  EXPECT_GE(s.stats().mac_rejected, static_cast<uint64_t>(VC_AUTH_MAX_REJECTS));
  s.stop();
}

TEST_F(SessionAuth, WrongKeyKeylessNodeAndReflectedProofAreRefused) {
  Key key = random_key();
  Recorder h;
  Server s(keyed(key), h);
  s.start();
  {
    Client c(s.port());  // holds another key: it cannot even accept the host's proof
    EXPECT_FALSE(c.handshake(random_key()));
  }
  {
    Client c(s.port());  // answers with a proof made with the wrong key
    c.hello(true);
    vc_auth_random(c.nn, sizeof c.nn);
    c.auth(VC_AUTH_CHALLENGE, c.nn, nullptr);
    vc_msg m{};
    int rc = 0;
    ASSERT_TRUE(c.next(&m, &rc));
    Key wrong = random_key();
    uint8_t proof[32];
    vc_auth_prove(proof, wrong.data(), VC_AUTH_ROLE_NODE, c.node, c.nn, m.u.auth.nonce);
    c.auth(VC_AUTH_PROOF, nullptr, proof);
    EXPECT_TRUE(c.closed_within(2000));
  }
  {
    Client c(s.port());  // reflects the host's own proof back
    c.hello(true);
    vc_auth_random(c.nn, sizeof c.nn);
    c.auth(VC_AUTH_CHALLENGE, c.nn, nullptr);
    vc_msg m{};
    int rc = 0;
    ASSERT_TRUE(c.next(&m, &rc));
    uint8_t reflected[32];
    std::memcpy(reflected, m.u.auth.proof, 32);
    c.auth(VC_AUTH_PROOF, nullptr, reflected);
    EXPECT_TRUE(c.closed_within(2000));
  }
  {
    Client c(s.port());  // keyless
    c.hello(false);
    EXPECT_TRUE(c.closed_within(2000));
  }
  {
    Client c(s.port());  // skips the proof and sends a heartbeat
    c.hello(true);
    vc_auth_random(c.nn, sizeof c.nn);
    c.auth(VC_AUTH_CHALLENGE, c.nn, nullptr);
    auto hb = c.heartbeat(nullptr, 5);
    c.raw(hb.data(), hb.size());
    EXPECT_TRUE(c.closed_within(2000));
  }
  EXPECT_TRUE(h.hellos.empty());          // the handler never saw any of them
  EXPECT_EQ(s.stats().auth_refused, 4u);  // the first client closed on its own before its proof
  s.stop();
}

TEST_F(SessionAuth, KeyedNodeOnAKeylessRigIsRefused) {
  Recorder h;
  ServerOptions o = keyed(random_key());
  o.key.clear();
  Server s(o, h);
  s.start();
  Client c(s.port());
  c.hello(true);
  EXPECT_TRUE(c.closed_within(2000));
  EXPECT_TRUE(h.hellos.empty());
  EXPECT_EQ(s.stats().auth_refused, 1u);
  s.stop();
}

}  // namespace
}  // namespace vc::session
