// Authenticated control (auth.h, SPEC.md "Authentication"): the key file, the challenge-response
// proofs, the per-message MAC trailer through the streaming decoder (forged, replayed, reordered) and
// the authenticated trigger datagram.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "voxcap/auth.h"
#include "voxcap/proto.h"

namespace {

using Key = std::array<uint8_t, VC_AUTH_KEY_SIZE>;
using Nonce = std::array<uint8_t, VC_AUTH_NONCE_SIZE>;

struct AuthTest : ::testing::Test {
  void SetUp() override { ASSERT_EQ(vc_auth_init(), 0); }
  std::string tmp(const std::string& name) {
    std::string dir = ::testing::TempDir() + "voxcap_auth_" + std::to_string(getpid());
    mkdir(dir.c_str(), 0700);
    std::string p = dir + "/" + name;
    std::remove(p.c_str());
    return p;
  }
};

TEST_F(AuthTest, KeyFileIsWrittenOwnerOnlyAndReadBack) {
  std::string p = tmp("rig.key");
  Key written{}, read{};
  char why[256];
  ASSERT_EQ(vc_key_write(p.c_str(), false, written.data(), why, sizeof why), 0) << why;
  struct stat st {};
  ASSERT_EQ(stat(p.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_EQ(st.st_size, 65);  // one line of 64 hex digits
  ASSERT_EQ(vc_key_load(p.c_str(), read.data(), why, sizeof why), 0) << why;
  EXPECT_EQ(read, written);
  // Not overwritten without the flag; a new key with it.
  EXPECT_EQ(vc_key_write(p.c_str(), false, nullptr, why, sizeof why), -EEXIST);
  EXPECT_NE(std::string(why).find("--force"), std::string::npos);
  Key second{};
  ASSERT_EQ(vc_key_write(p.c_str(), true, second.data(), why, sizeof why), 0) << why;
  EXPECT_NE(second, written);
}

TEST_F(AuthTest, KeyFileReadableByOthersOrMalformedIsRefused) {
  std::string p = tmp("open.key");
  char why[256];
  ASSERT_EQ(vc_key_write(p.c_str(), false, nullptr, why, sizeof why), 0);
  Key k{};
  ASSERT_EQ(chmod(p.c_str(), 0640), 0);
  EXPECT_EQ(vc_key_load(p.c_str(), k.data(), why, sizeof why), -EACCES);
  EXPECT_NE(std::string(why).find("chmod 600"), std::string::npos) << why;
  ASSERT_EQ(chmod(p.c_str(), 0604), 0);
  EXPECT_EQ(vc_key_load(p.c_str(), k.data(), why, sizeof why), -EACCES);
  for (const char* text : {"abc\n", "", "zz00000000000000000000000000000000000000000000000000000000000000\n",
                           "0000000000000000000000000000000000000000000000000000000000000000\nextra\n"}) {
    std::string q = tmp("bad.key");
    std::ofstream(q) << text;
    ASSERT_EQ(chmod(q.c_str(), 0600), 0);
    EXPECT_EQ(vc_key_load(q.c_str(), k.data(), why, sizeof why), -EINVAL) << text;
    EXPECT_STRNE(why, "");
  }
  EXPECT_EQ(vc_key_load(tmp("missing.key").c_str(), k.data(), why, sizeof why), -ENOENT);
  EXPECT_EQ(vc_key_load("/dev/null", k.data(), why, sizeof why), -EINVAL);
}

TEST_F(AuthTest, ProofsBindKeyRoleNodeAndBothNonces) {
  Key key{}, other{};
  Nonce nn{}, nh{};
  vc_auth_random(key.data(), key.size());
  vc_auth_random(other.data(), other.size());
  vc_auth_random(nn.data(), nn.size());
  vc_auth_random(nh.data(), nh.size());
  uint8_t proof[VC_AUTH_PROOF_SIZE];
  vc_auth_prove(proof, key.data(), VC_AUTH_ROLE_HOST, 3, nn.data(), nh.data());
  EXPECT_TRUE(vc_auth_verify(proof, key.data(), VC_AUTH_ROLE_HOST, 3, nn.data(), nh.data()));
  // Reflection: the host's proof is not the node's.
  EXPECT_FALSE(vc_auth_verify(proof, key.data(), VC_AUTH_ROLE_NODE, 3, nn.data(), nh.data()));
  // Another node, another key, a fresh nonce on either side: no pass (replay of an old proof).
  EXPECT_FALSE(vc_auth_verify(proof, key.data(), VC_AUTH_ROLE_HOST, 4, nn.data(), nh.data()));
  EXPECT_FALSE(vc_auth_verify(proof, other.data(), VC_AUTH_ROLE_HOST, 3, nn.data(), nh.data()));
  Nonce fresh = nn;
  fresh[31] ^= 1;
  EXPECT_FALSE(vc_auth_verify(proof, key.data(), VC_AUTH_ROLE_HOST, 3, fresh.data(), nh.data()));
  EXPECT_FALSE(vc_auth_verify(proof, key.data(), VC_AUTH_ROLE_HOST, 3, nn.data(), fresh.data()));
}

TEST_F(AuthTest, AuthMessageRoundTripAndRejections) {
  vc_auth_msg m{};
  m.step = VC_AUTH_RESPONSE;
  for (size_t i = 0; i < 32; i++)
    m.nonce[i] = static_cast<uint8_t>(i), m.proof[i] = static_cast<uint8_t>(100 + i);
  vc_header h{};
  h.node_id = 2;
  std::vector<uint8_t> buf(256);
  size_t len = 0;
  ASSERT_EQ(vc_encode_auth(buf.data(), buf.size(), &len, &h, &m), 0);
  EXPECT_EQ(len, VC_PROTO_HEADER_SIZE + 68u);
  vc_msg out{};
  size_t used = 0;
  ASSERT_EQ(vc_msg_decode(buf.data(), len, 0, &out, &used, nullptr), 1);
  EXPECT_EQ(out.hdr.type, VC_MSG_AUTH);
  EXPECT_EQ(out.u.auth.step, VC_AUTH_RESPONSE);
  EXPECT_EQ(0, std::memcmp(out.u.auth.nonce, m.nonce, 32));
  EXPECT_EQ(0, std::memcmp(out.u.auth.proof, m.proof, 32));
  m.step = 4;
  EXPECT_EQ(vc_encode_auth(buf.data(), buf.size(), &len, &h, &m), VC_PROTO_EFIELD);
}

struct Sealed {
  std::vector<uint8_t> bytes;
};

Sealed heartbeat(vc_mac* tx, uint64_t t) {
  std::vector<uint8_t> b(VC_PROTO_HEADER_SIZE + 12 + VC_AUTH_TRAILER_SIZE);
  size_t len = 0, sealed = 0;
  vc_header h{};
  h.node_id = 1;
  vc_heartbeat hb{t, VC_STATE_READY};
  EXPECT_EQ(vc_encode_heartbeat(b.data(), b.size(), &len, &h, &hb), 0);
  EXPECT_EQ(vc_mac_seal(tx, b.data(), len, b.size(), &sealed), 0);
  b.resize(sealed);
  return {b};
}

struct MacStream : AuthTest {
  void SetUp() override {
    AuthTest::SetUp();
    vc_auth_random(key.data(), key.size());
    vc_auth_random(nn.data(), nn.size());
    vc_auth_random(nh.data(), nh.size());
    vc_auth_session(key.data(), 1, nn.data(), nh.data(), &tx, &unused);
    vc_mac rx = tx;
    char why[64];
    ASSERT_EQ(vc_decoder_new(0, &dec, why, sizeof why), 0);
    ASSERT_EQ(vc_decoder_set_mac(dec, &rx), 0);
  }
  void TearDown() override { vc_decoder_free(dec); }
  // Feeds bytes, returns the codes next() gave (1 for a message, with its sender_time_ns in times).
  std::vector<int> feed(const std::vector<uint8_t>& b, std::vector<uint64_t>* times = nullptr) {
    std::vector<int> codes;
    size_t off = 0, used = 0;
    while (off < b.size()) {
      EXPECT_EQ(vc_decoder_feed(dec, b.data() + off, b.size() - off, &used), 0);
      off += used;
      vc_msg m;
      int rc;
      while ((rc = vc_decoder_next(dec, &m)) != 0) {
        codes.push_back(rc);
        if (rc == 1 && times) times->push_back(m.u.heartbeat.sender_time_ns);
        if (rc == 1) EXPECT_EQ(m.hdr.payload_len, 12u);  // the trailer is not the message's
      }
    }
    return codes;
  }
  Key key{};
  Nonce nn{}, nh{};
  vc_mac tx{}, unused{};
  vc_decoder* dec = nullptr;
};

TEST_F(MacStream, SealedMessagesPassInOrder) {
  std::vector<uint64_t> times;
  for (uint64_t t = 1; t <= 5; t++) EXPECT_EQ(feed(heartbeat(&tx, t).bytes, &times), std::vector<int>{1});
  EXPECT_EQ(times, (std::vector<uint64_t>{1, 2, 3, 4, 5}));
}

TEST_F(MacStream, ForgedMessagesAreRejectedAndTheStreamGoesOn) {
  // No MAC at all (a keyless sender's bytes).
  std::vector<uint8_t> plain(64);
  size_t len = 0;
  vc_header h{};
  vc_heartbeat hb{7, VC_STATE_READY};
  ASSERT_EQ(vc_encode_heartbeat(plain.data(), plain.size(), &len, &h, &hb), 0);
  plain.resize(len);
  EXPECT_EQ(feed(plain), std::vector<int>{VC_PROTO_EMAC});
  // Sealed with another key (a stranger who does not hold the rig key).
  vc_mac stranger{};
  vc_auth_random(stranger.key, sizeof stranger.key);
  EXPECT_EQ(feed(heartbeat(&stranger, 8).bytes), std::vector<int>{VC_PROTO_EMAC});
  // One payload byte changed and the CRCs fixed up: the MAC still catches it.
  vc_mac copy = tx;
  auto b = heartbeat(&copy, 9).bytes;
  b[VC_PROTO_HEADER_SIZE] ^= 1;
  vc_header hh{};
  hh.type = VC_MSG_HEARTBEAT;
  hh.flags = VC_FLAG_MAC;
  hh.version_major = b[4];
  hh.version_minor = b[5];
  std::vector<uint8_t> refr(b.size());
  ASSERT_EQ(vc_frame_encode(refr.data(), refr.size(), &len, &hh, b.data() + VC_PROTO_HEADER_SIZE,
                            b.size() - VC_PROTO_HEADER_SIZE),
            0);
  EXPECT_EQ(feed(refr), std::vector<int>{VC_PROTO_EMAC});
  // The real sender's next message still passes: nothing above moved the counter.
  std::vector<uint64_t> times;
  EXPECT_EQ(feed(heartbeat(&tx, 10).bytes, &times), std::vector<int>{1});
  EXPECT_EQ(times, std::vector<uint64_t>{10});
}

TEST_F(MacStream, ReplayedAndReorderedMessagesAreRejected) {
  auto a = heartbeat(&tx, 1).bytes, b = heartbeat(&tx, 2).bytes, c = heartbeat(&tx, 3).bytes;
  EXPECT_EQ(feed(a), std::vector<int>{1});
  EXPECT_EQ(feed(a), std::vector<int>{VC_PROTO_EREPLAY});  // replayed
  EXPECT_EQ(feed(c), std::vector<int>{VC_PROTO_EORDER});   // c before b: reordered
  std::vector<uint64_t> times;
  EXPECT_EQ(feed(b, &times), std::vector<int>{1});
  EXPECT_EQ(feed(c, &times), std::vector<int>{1});
  EXPECT_EQ(times, (std::vector<uint64_t>{2, 3}));
  EXPECT_FALSE(vc_proto_error_is_fatal(VC_PROTO_EMAC));
  EXPECT_FALSE(vc_proto_error_is_fatal(VC_PROTO_EREPLAY));
  EXPECT_FALSE(vc_proto_error_is_fatal(VC_PROTO_EORDER));
}

TEST_F(AuthTest, DirectionsHaveTheirOwnKeys) {
  Key key{};
  Nonce nn{}, nh{};
  vc_auth_random(key.data(), key.size());
  vc_auth_random(nn.data(), nn.size());
  vc_auth_random(nh.data(), nh.size());
  vc_mac n2h{}, h2n{};
  vc_auth_session(key.data(), 1, nn.data(), nh.data(), &n2h, &h2n);
  EXPECT_NE(0, std::memcmp(n2h.key, h2n.key, VC_AUTH_KEY_SIZE));
  // A message the node sent cannot be reflected back to it as the host's.
  auto b = heartbeat(&n2h, 1).bytes;
  vc_proto_diag d{};
  EXPECT_EQ(vc_mac_open(&h2n, b.data(), b.size(), &d), VC_PROTO_EMAC);
}

TEST_F(AuthTest, TriggerDatagramCarriesMacAndCounter) {
  Key key{};
  vc_auth_random(key.data(), key.size());
  vc_mac tx{}, rx{};
  vc_auth_trigger_key(key.data(), &tx);
  vc_auth_trigger_key(key.data(), &rx);
  tx.counter = 1000;
  std::array<uint8_t, VC_TRIGGER_DGRAM_MAC_SIZE> d1{}, d2{}, d3{};
  ASSERT_EQ(vc_trigger_dgram_encode_mac(d1.data(), 5, 50, &tx), 0);
  ASSERT_EQ(vc_trigger_dgram_encode_mac(d2.data(), 6, 60, &tx), 0);
  ASSERT_EQ(vc_trigger_dgram_encode_mac(d3.data(), 7, 70, &tx), 0);
  uint64_t seq = 0, t = 0;
  ASSERT_EQ(vc_trigger_dgram_decode_mac(d1.data(), d1.size(), &rx, &seq, &t), 0);
  EXPECT_EQ(seq, 5u);
  EXPECT_EQ(t, 50u);
  ASSERT_EQ(vc_trigger_dgram_decode_mac(d3.data(), d3.size(), &rx, &seq, &t), 0);  // d2 lost: fine
  EXPECT_EQ(seq, 7u);
  EXPECT_EQ(vc_trigger_dgram_decode_mac(d2.data(), d2.size(), &rx, &seq, &t), VC_PROTO_EREPLAY);
  EXPECT_EQ(vc_trigger_dgram_decode_mac(d3.data(), d3.size(), &rx, &seq, &t), VC_PROTO_EREPLAY);
  // Forged: a changed seq, or a stranger's key.
  auto f = d3;
  f[8] ^= 0x40;
  vc_mac rx2{};
  vc_auth_trigger_key(key.data(), &rx2);
  EXPECT_EQ(vc_trigger_dgram_decode_mac(f.data(), f.size(), &rx2, &seq, &t), VC_PROTO_EMAC);
  vc_mac stranger{};
  vc_auth_random(stranger.key, sizeof stranger.key);
  ASSERT_EQ(vc_trigger_dgram_encode_mac(f.data(), 9, 90, &stranger), 0);
  EXPECT_EQ(vc_trigger_dgram_decode_mac(f.data(), f.size(), &rx2, &seq, &t), VC_PROTO_EMAC);
  // A version-1 datagram is not accepted where the MAC is required.
  std::array<uint8_t, VC_TRIGGER_DGRAM_MAC_SIZE> v1{};
  ASSERT_EQ(vc_trigger_dgram_encode(v1.data(), 9, 90), 0);
  EXPECT_EQ(vc_trigger_dgram_decode_mac(v1.data(), VC_TRIGGER_DGRAM_SIZE, &rx2, &seq, &t), -EBADMSG);
  EXPECT_EQ(vc_trigger_dgram_decode_mac(v1.data(), v1.size(), &rx2, &seq, &t), -EBADMSG);
}

}  // namespace
