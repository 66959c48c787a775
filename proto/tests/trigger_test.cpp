// The emulated trigger datagram: exact bytes as in SPEC.md, round trip, and each rejection.
#include <gtest/gtest.h>

#include <array>
#include <cerrno>

#include "voxcap/proto.h"

namespace {

TEST(TriggerDgram, BytesAsSpecified) {
  std::array<uint8_t, VC_TRIGGER_DGRAM_SIZE> b{};
  ASSERT_EQ(vc_trigger_dgram_encode(b.data(), 0x0102030405060708ull, 0x1112131415161718ull), 0);
  const std::array<uint8_t, 24> expected{'V',  'X',  'T',  'R',  1,    0,    0,    0,
                                         0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01,
                                         0x18, 0x17, 0x16, 0x15, 0x14, 0x13, 0x12, 0x11};
  EXPECT_EQ(b, expected);
  uint64_t seq = 0, t = 0;
  ASSERT_EQ(vc_trigger_dgram_decode(b.data(), b.size(), &seq, &t), 0);
  EXPECT_EQ(seq, 0x0102030405060708ull);
  EXPECT_EQ(t, 0x1112131415161718ull);
}

TEST(TriggerDgram, Rejections) {
  std::array<uint8_t, VC_TRIGGER_DGRAM_SIZE + 1> b{};
  ASSERT_EQ(vc_trigger_dgram_encode(b.data(), 7, 9), 0);
  uint64_t seq = 42, t = 43;
  EXPECT_EQ(vc_trigger_dgram_decode(b.data(), 23, &seq, &t), -EBADMSG);
  EXPECT_EQ(vc_trigger_dgram_decode(b.data(), 25, &seq, &t), -EBADMSG);
  auto bad = b;
  bad[0] = 'W';
  EXPECT_EQ(vc_trigger_dgram_decode(bad.data(), 24, &seq, &t), -EBADMSG);
  bad = b;
  bad[4] = 2;  // version 2
  EXPECT_EQ(vc_trigger_dgram_decode(bad.data(), 24, &seq, &t), -EBADMSG);
  EXPECT_EQ(seq, 42u);  // outputs untouched on error
  EXPECT_EQ(t, 43u);
  bad = b;
  bad[6] = 0x80;  // reserved flags are ignored
  EXPECT_EQ(vc_trigger_dgram_decode(bad.data(), 24, nullptr, nullptr), 0);
  EXPECT_EQ(vc_trigger_dgram_decode(nullptr, 24, &seq, &t), -EINVAL);
  EXPECT_EQ(vc_trigger_dgram_encode(nullptr, 1, 2), -EINVAL);
}

}  // namespace
