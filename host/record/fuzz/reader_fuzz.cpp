// libFuzzer target: the session reader on arbitrary bytes. Never crash, hang or read out of bounds,
// and keep its invariants (iteration yields exactly the records the summary counts; valid + ignored
// bytes = the input). The first input byte picks a mode:
//   even: the bytes are a records.vcr as is (exercises framing: magic, header CRC, lengths, torn tails);
//   odd:  the bytes are re-framed first: headers get the magic, consecutive record numbers, a body
//         length that fits and fresh CRCs, so the body decoders see arbitrary bodies behind valid
//         checksums (a random body never gets past a CRC otherwise). Each body is also fed to every
//         body decoder directly.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "voxcap/crc32c.h"
#include "voxcap/record/format.hpp"
#include "voxcap/record/pose.hpp"
#include "voxcap/record/recorder.hpp"

namespace {

using namespace vc::record;

void put32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}

void reframe(std::vector<uint8_t>& b) {
  size_t off = 0;
  for (uint64_t index = 0; off + format::kHeaderBytes + format::kTrailerBytes <= b.size(); ++index) {
    uint8_t* h = b.data() + off;
    put32(h, format::kMagic);
    h[4] = static_cast<uint8_t>(1 + h[4] % 6);  // a known type
    h[5] = h[6] = h[7] = 0;
    const size_t room = b.size() - off - format::kHeaderBytes - format::kTrailerBytes;
    uint32_t body = static_cast<uint32_t>(h[8] | h[9] << 8);  // the low 16 bits as written, capped
    if (body > room) body = static_cast<uint32_t>(room);
    put32(h + 8, body);
    for (int i = 0; i < 8; ++i) h[12 + i] = static_cast<uint8_t>(index >> (8 * i));
    put32(h + 20, vc_crc32c(0, h, 20));
    const size_t end = off + format::kHeaderBytes + body;
    put32(b.data() + end, vc_crc32c(0, h, format::kHeaderBytes + body));
    off = end + format::kTrailerBytes;
  }
}

void decode_all(std::span<const uint8_t> body) {
  std::string why;
  format::BeginRecord b;
  FrameRecord f;
  FeatureRecord fe;
  PoseRecord p;
  StatsRecord s;
  format::EndRecord e;
  (void)format::decode_body(body, &b, &why);
  if (format::decode_body(body, &f, &why)) {
    // Anything the decoder accepts re-encodes to the same bytes.
    std::vector<uint8_t> again;
    format::encode(f, 0, again);
    if (again.size() != body.size() + format::kHeaderBytes + format::kTrailerBytes ||
        std::memcmp(again.data() + format::kHeaderBytes, body.data(), body.size()) != 0)
      __builtin_trap();
  }
  (void)format::decode_body(body, &fe, &why);
  if (format::decode_body(body, &p, &why)) {
    // A pose record of any content: the fitted-pose reader checks it, never trusts it.
    vc::pipeline::Pose pose;
    if (from_record(p, &pose, &why) && !pose.valid() && pose.state != vc::pipeline::PoseState::None)
      __builtin_trap();
  }
  (void)format::decode_body(body, &s, &why);
  (void)format::decode_body(body, &e, &why);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  std::vector<uint8_t> bytes(data + 1, data + size);
  if (data[0] & 1) {
    reframe(bytes);
    if (bytes.size() > format::kHeaderBytes + format::kTrailerBytes)
      decode_all(
          {bytes.data() + format::kHeaderBytes, bytes.size() - format::kHeaderBytes - format::kTrailerBytes});
  }
  const size_t n = bytes.size();
  Reader reader = Reader::from_bytes(std::move(bytes));
  const Reader::Summary& s = reader.summary_ref();
  if (s.valid_bytes + s.truncated_bytes != n || s.valid_bytes > n) __builtin_trap();
  Record r;
  uint64_t records = 0;
  while (reader.next(r)) ++records;
  if (records != s.records) __builtin_trap();
  return 0;
}
