// The udp trigger backend over loopback: datagrams in, pulses out, gaps/late/duplicates/garbage counted.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>
#include <vector>

#include "voxcap/auth.h"
#include "voxcap/edge/trigger.h"
#include "voxcap/proto.h"

namespace {

class UdpTrigger : public ::testing::Test {
 protected:
  void SetUp() override {
    vc_trigger_config cfg;
    vc_trigger_config_init(&cfg);
    cfg.backend = "udp";
    cfg.port = 0;  // any free port
    char why[256];
    ASSERT_EQ(vc_trigger_open(&cfg, &trig_, why, sizeof why), 0) << why;
    vc_trigger_info info;
    vc_trigger_get_info(trig_, &info);
    ASSERT_NE(info.port, 0);
    port_ = info.port;
    tx_ = socket(AF_INET, SOCK_DGRAM, 0);
    ASSERT_GE(tx_, 0);
  }
  void TearDown() override {
    vc_trigger_free(trig_);
    if (tx_ >= 0) close(tx_);
  }
  void send_raw(const void* buf, size_t len) {
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(port_);
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(sendto(tx_, buf, len, 0, reinterpret_cast<sockaddr*>(&to), sizeof to), (ssize_t)len);
  }
  void send_pulse(uint64_t seq, uint64_t t_ns) {
    uint8_t d[VC_TRIGGER_DGRAM_SIZE];
    ASSERT_EQ(vc_trigger_dgram_encode(d, seq, t_ns), 0);
    send_raw(d, sizeof d);
  }
  vc_trigger* trig_ = nullptr;
  uint16_t port_ = 0;
  int tx_ = -1;
};

}  // namespace

TEST_F(UdpTrigger, DeliversPulsesInOrder) {
  for (uint64_t s = 0; s < 20; s++) send_pulse(s, 1000000000ull + s * 16666667ull);
  for (uint64_t s = 0; s < 20; s++) {
    vc_pulse p;
    ASSERT_EQ(vc_trigger_wait(trig_, 2000, &p), 0) << vc_trigger_last_error(trig_);
    EXPECT_EQ(p.seq, s);
    EXPECT_EQ(p.t_ns, 1000000000ull + s * 16666667ull);
  }
  vc_trigger_stats st;
  vc_trigger_get_stats(trig_, &st);
  EXPECT_EQ(st.pulses, 20u);
  EXPECT_EQ(st.lost, 0u);
}

TEST_F(UdpTrigger, DetectsGapsLateAndDuplicateDatagrams) {
  for (uint64_t s : {5, 6, 9, 8, 8, 10}) send_pulse(s, s * 1000);
  std::vector<uint64_t> got;
  vc_pulse p;
  while (vc_trigger_wait(trig_, 300, &p) == 0) got.push_back(p.seq);
  EXPECT_EQ(got, (std::vector<uint64_t>{5, 6, 9, 8, 10}));
  vc_trigger_stats st;
  vc_trigger_get_stats(trig_, &st);
  EXPECT_EQ(st.pulses, 5u);
  EXPECT_EQ(st.lost, 1u);  // 7 never came; 8 came late
  EXPECT_EQ(st.late, 1u);
  EXPECT_EQ(st.duplicate, 1u);
}

TEST_F(UdpTrigger, DropsUndecodableDatagrams) {
  uint8_t d[VC_TRIGGER_DGRAM_SIZE];
  vc_trigger_dgram_encode(d, 1, 2);
  d[0] ^= 0xff;  // bad magic
  send_raw(d, sizeof d);
  send_raw("hello", 5);  // wrong size
  send_pulse(3, 4);
  vc_pulse p;
  ASSERT_EQ(vc_trigger_wait(trig_, 2000, &p), 0);
  EXPECT_EQ(p.seq, 3u);
  vc_trigger_stats st;
  vc_trigger_get_stats(trig_, &st);
  EXPECT_EQ(st.invalid, 2u);
}

TEST_F(UdpTrigger, TimesOutWithAMessage) {
  vc_pulse p;
  EXPECT_EQ(vc_trigger_wait(trig_, 20, &p), -ETIMEDOUT);
  std::string err = vc_trigger_last_error(trig_);
  EXPECT_EQ(err, "udp: 127.0.0.1:" + std::to_string(port_) + ": no trigger pulse within the timeout");
  EXPECT_EQ(vc_trigger_wait(trig_, 0, &p), -ETIMEDOUT);  // poll mode
}

TEST_F(UdpTrigger, ExposesAPollableFd) {
  int fd = vc_trigger_fd(trig_);
  EXPECT_GE(fd, 0);
}

TEST_F(UdpTrigger, PortInUseGivesAClearError) {
  vc_trigger_config cfg;
  vc_trigger_config_init(&cfg);
  cfg.backend = "udp";
  cfg.port = port_;
  char why[256];
  vc_trigger* other = nullptr;
  EXPECT_EQ(vc_trigger_open(&cfg, &other, why, sizeof why), -EADDRINUSE);
  EXPECT_EQ(std::string(why),
            "udp: 127.0.0.1:" + std::to_string(port_) + ": cannot bind: Address already in use");
  EXPECT_EQ(other, nullptr);
}

TEST(UdpTriggerConfig, BadAddressIsRejected) {
  vc_trigger_config cfg;
  vc_trigger_config_init(&cfg);
  cfg.backend = "udp";
  cfg.bind_address = "localhost";
  cfg.port = 47000;
  char why[256];
  vc_trigger* t = nullptr;
  EXPECT_EQ(vc_trigger_open(&cfg, &t, why, sizeof why), -EINVAL);
  EXPECT_STREQ(why, "udp: localhost:47000: bind_address must be an IPv4 address such as 127.0.0.1");
}

// Issue #13: one datagram with seq 100000 to an edge's trigger port made that edge's frames 100000
// and stopped the rig. It is dropped now (counted), and the host's pulses go on.
TEST_F(UdpTrigger, DropsAForgedSeqJump) {
  send_pulse(500, 1);
  send_pulse(100000, 2);
  send_pulse(501, 3);
  std::vector<uint64_t> got;
  vc_pulse p;
  while (vc_trigger_wait(trig_, 300, &p) == 0) got.push_back(p.seq);
  EXPECT_EQ(got, (std::vector<uint64_t>{500, 501}));
  vc_trigger_stats st;
  vc_trigger_get_stats(trig_, &st);
  EXPECT_EQ(st.jumps, 1u);
  EXPECT_EQ(st.last_jump_seq, 100000u);
  EXPECT_EQ(st.lost, 0u);
}

// With the host's address known, a datagram from any other sender is dropped (loopback has many
// addresses: the "host" is 127.0.0.2 here, the stranger 127.0.0.1).
TEST(UdpTriggerSource, TakesPulsesOnlyFromTheHostsAddress) {
  vc_trigger_config cfg;
  vc_trigger_config_init(&cfg);
  cfg.backend = "udp";
  cfg.source_address = "127.0.0.2";
  vc_trigger* trig = nullptr;
  char why[256];
  ASSERT_EQ(vc_trigger_open(&cfg, &trig, why, sizeof why), 0) << why;
  vc_trigger_info info;
  vc_trigger_get_info(trig, &info);
  auto send_from = [&](const char* from, uint64_t seq) {
    int fd = socket(AF_INET, SOCK_DGRAM, 0);
    ASSERT_GE(fd, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    ASSERT_EQ(inet_pton(AF_INET, from, &a.sin_addr), 1);
    ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0) << std::strerror(errno);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(info.port);
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    uint8_t d[VC_TRIGGER_DGRAM_SIZE];
    ASSERT_EQ(vc_trigger_dgram_encode(d, seq, seq), 0);
    EXPECT_EQ(sendto(fd, d, sizeof d, 0, reinterpret_cast<sockaddr*>(&to), sizeof to), (ssize_t)sizeof d);
    close(fd);
  };
  send_from("127.0.0.1", 7);
  send_from("127.0.0.2", 8);
  send_from("127.0.0.1", 9);
  std::vector<uint64_t> got;
  vc_pulse p;
  while (vc_trigger_wait(trig, 300, &p) == 0) got.push_back(p.seq);
  EXPECT_EQ(got, (std::vector<uint64_t>{8}));
  vc_trigger_stats st;
  vc_trigger_get_stats(trig, &st);
  EXPECT_EQ(st.foreign, 2u);
  vc_trigger_free(trig);
}

// A key rotation under way (host/deploy/README.md "Keys"): with the rig key and the next one, a pulse
// signed with either is taken, on one counter (a counter taken under one key is not taken again under
// the other); a stranger's key is still forged.
TEST(UdpTriggerKeys, EitherKeyOfARotationOnOneCounter) {
  ASSERT_EQ(vc_auth_init(), 0);
  uint8_t a[VC_AUTH_KEY_SIZE], b[VC_AUTH_KEY_SIZE], c[VC_AUTH_KEY_SIZE];
  vc_auth_random(a, sizeof a);
  vc_auth_random(b, sizeof b);
  vc_auth_random(c, sizeof c);
  vc_trigger_config cfg;
  vc_trigger_config_init(&cfg);
  cfg.backend = "udp";
  cfg.key = a;
  cfg.next_key = b;
  vc_trigger* trig = nullptr;
  char why[256];
  ASSERT_EQ(vc_trigger_open(&cfg, &trig, why, sizeof why), 0) << why;
  vc_trigger_info info;
  vc_trigger_get_info(trig, &info);
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(fd, 0);
  auto send_signed = [&](const uint8_t* key, uint64_t counter, uint64_t seq) {
    vc_mac tx;
    vc_auth_trigger_key(key, &tx);
    tx.counter = counter;
    uint8_t d[VC_TRIGGER_DGRAM_MAC_SIZE];
    ASSERT_EQ(vc_trigger_dgram_encode_mac(d, seq, seq, &tx), 0);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(info.port);
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(sendto(fd, d, sizeof d, 0, reinterpret_cast<sockaddr*>(&to), sizeof to), (ssize_t)sizeof d);
  };
  send_signed(a, 10, 1);
  send_signed(b, 11, 2);
  send_signed(c, 12, 3);  // a stranger
  send_signed(a, 11, 4);  // counter 11 was taken (under b)
  send_signed(b, 12, 5);
  std::vector<uint64_t> got;
  vc_pulse p;
  while (vc_trigger_wait(trig, 300, &p) == 0) got.push_back(p.seq);
  EXPECT_EQ(got, (std::vector<uint64_t>{1, 2, 5}));
  vc_trigger_stats st;
  vc_trigger_get_stats(trig, &st);
  EXPECT_EQ(st.forged, 2u);
  close(fd);
  vc_trigger_free(trig);
}
