// The thin C++ wrapper of proto's C library (voxcap/proto.h, voxcap/rle.h), target vc_proto_cxx: encoders
// that return the whole message and cannot fail silently, and the one place where the library's error
// codes become exceptions (vc::proto::ProtoError, with vc_proto_strerror's text). The structs are the C
// library's own; SPEC.md and proto.h say what every field means and which bodies are valid.
//
//   vc_config c = ...;
//   std::vector<uint8_t> msg = vc::proto::encode(c);              // host -> node: header {} is fine
//   auto hull = vc::proto::encode_hull_bits(bits, nbits, grid, hdr); // node_id, seq, t_trigger_ns from hdr
//
// Every encode* returns a new vector of exactly the message's bytes (header and payload) or throws
// ProtoError with the encoder's code: a body the decoder would reject (VC_PROTO_E*), -EINVAL. Untrusted
// input is not exceptional: decode_trigger() returns std::nullopt for bytes that are not a datagram.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "voxcap/proto.h"
#include "voxcap/rle.h"

namespace vc::proto {

// A negative code of the C library as an exception. what(): "<context>: <vc_proto_strerror(code)>
// (<vc_proto_error_name(code)>)", e.g. "encoding FEATURES: count over a protocol limit (VC_PROTO_ELIMIT)".
class ProtoError : public std::runtime_error {
 public:
  ProtoError(int code, const std::string& context);
  int code() const noexcept { return code_; }
  // vc_proto_error_name(code()): "VC_PROTO_ELIMIT", "ENOSPC", ...; a static string.
  const char* name() const noexcept;

 private:
  int code_;
};

// rc when rc >= 0; throws ProtoError(rc, context) when it is negative (the message is built only then).
int check(int rc, const char* context);

using Bytes = std::vector<uint8_t>;

// One message per call. hdr gives node_id, flags, seq and t_trigger_ns (the encoder sets the rest);
// the default {} is what the host's messages not about a frame carry.
Bytes encode(const vc_hello& m, const vc_header& hdr = {});
Bytes encode(const vc_config& m, const vc_header& hdr = {});
Bytes encode(const vc_background& m, const vc_header& hdr = {});
Bytes encode(const vc_hull& m, const vc_header& hdr = {});  // m.rle: m.rle_len bytes of RLE
Bytes encode(const vc_features& m, const vc_header& hdr = {});
Bytes encode(const vc_stats& m, const vc_header& hdr = {});
Bytes encode(const vc_heartbeat& m, const vc_header& hdr = {});
Bytes encode(const vc_error& m, const vc_header& hdr = {});       // m.text: m.text_len bytes, no NUL
Bytes encode(const vc_silhouette& m, const vc_header& hdr = {});  // m.rle: m.rle_len bytes of RLE
Bytes encode_start(const vc_header& hdr = {});
Bytes encode_stop(const vc_header& hdr = {});
// HULL straight from a bitset of nbits voxels (bits holds at least ceil(nbits / 8) bytes).
Bytes encode_hull_bits(std::span<const uint8_t> bits, size_t nbits, uint32_t grid_id,
                       const vc_header& hdr = {});
// SILHOUETTE straight from a bitset of width*height bits (pixel x + width*y, LSB-first; bits holds at
// least ceil(width*height / 8) bytes).
Bytes encode_silhouette_bits(std::span<const uint8_t> bits, uint16_t camera, uint16_t scale, uint16_t width,
                             uint16_t height, const vc_header& hdr = {});
// Any known message, dispatched on msg.hdr.type (-EINVAL for unknown types).
Bytes encode(const vc_msg& msg);

// ---- The emulated trigger datagram (SPEC.md "Trigger datagram") -------------------------------------
using TriggerDatagram = std::array<uint8_t, VC_TRIGGER_DGRAM_SIZE>;
struct TriggerPulse {
  uint64_t seq = 0;   // trigger pulse counter
  uint64_t t_ns = 0;  // host CLOCK_MONOTONIC of the pulse edge
};
TriggerDatagram encode_trigger(uint64_t seq, uint64_t t_ns);
// The pulse, or std::nullopt unless bytes are a datagram of this version (size, magic, version).
std::optional<TriggerPulse> decode_trigger(std::span<const uint8_t> bytes);

// ---- RLE (rle.h) ------------------------------------------------------------------------------------
// Validates a stream and counts its runs and bits; throws ProtoError (-EBADMSG, ...) when malformed.
vc_rle_info rle_inspect(std::span<const uint8_t> rle);

}  // namespace vc::proto
