// The thin C++ wrapper of proto's C library (see voxcap/proto.hpp).
#include "voxcap/proto.hpp"

#include <cerrno>
#include <string>

namespace vc::proto {
namespace {

std::string describe(int code, const std::string& context) {
  return context + ": " + vc_proto_strerror(code) + " (" + vc_proto_error_name(code) + ")";
}

std::string encoding(uint16_t type) {
  const char* name = vc_msg_type_name(type);
  return name ? std::string("encoding ") + name : "encoding message type " + std::to_string(type);
}

// Runs enc(buf, cap, &len) into a stack buffer that holds most messages and returns a vector of exactly
// the message; a larger message is encoded once more at the size the encoder asked for (-ENOSPC).
template <class Encode>
Bytes encode_with(uint16_t type, Encode&& enc) {
  std::array<uint8_t, 2048> small;
  size_t len = 0;
  int rc = enc(small.data(), small.size(), &len);
  if (rc == 0) return Bytes(small.begin(), small.begin() + static_cast<std::ptrdiff_t>(len));
  if (rc == -ENOSPC) {
    Bytes out(len);
    rc = enc(out.data(), out.size(), &len);
    if (rc == 0) {
      out.resize(len);
      return out;
    }
  }
  throw ProtoError(rc, encoding(type));
}

}  // namespace

ProtoError::ProtoError(int code, const std::string& context)
    : std::runtime_error(describe(code, context)), code_(code) {}

const char* ProtoError::name() const noexcept {
  return vc_proto_error_name(code_);
}

int check(int rc, const char* context) {
  if (rc < 0) throw ProtoError(rc, context);
  return rc;
}

Bytes encode(const vc_hello& m, const vc_header& hdr) {
  return encode_with(VC_MSG_HELLO, [&](uint8_t* b, size_t cap, size_t* len) {
    return vc_encode_hello(b, cap, len, &hdr, &m);
  });
}

Bytes encode(const vc_config& m, const vc_header& hdr) {
  return encode_with(VC_MSG_CONFIG, [&](uint8_t* b, size_t cap, size_t* len) {
    return vc_encode_config(b, cap, len, &hdr, &m);
  });
}

Bytes encode(const vc_background& m, const vc_header& hdr) {
  return encode_with(VC_MSG_BACKGROUND, [&](uint8_t* b, size_t cap, size_t* len) {
    return vc_encode_background(b, cap, len, &hdr, &m);
  });
}

Bytes encode(const vc_hull& m, const vc_header& hdr) {
  return encode_with(VC_MSG_HULL, [&](uint8_t* b, size_t cap, size_t* len) {
    return vc_encode_hull(b, cap, len, &hdr, &m);
  });
}

Bytes encode(const vc_features& m, const vc_header& hdr) {
  return encode_with(VC_MSG_FEATURES, [&](uint8_t* b, size_t cap, size_t* len) {
    return vc_encode_features(b, cap, len, &hdr, &m);
  });
}

Bytes encode(const vc_stats& m, const vc_header& hdr) {
  return encode_with(VC_MSG_STATS, [&](uint8_t* b, size_t cap, size_t* len) {
    return vc_encode_stats(b, cap, len, &hdr, &m);
  });
}

Bytes encode(const vc_heartbeat& m, const vc_header& hdr) {
  return encode_with(VC_MSG_HEARTBEAT, [&](uint8_t* b, size_t cap, size_t* len) {
    return vc_encode_heartbeat(b, cap, len, &hdr, &m);
  });
}

Bytes encode(const vc_error& m, const vc_header& hdr) {
  return encode_with(VC_MSG_ERROR, [&](uint8_t* b, size_t cap, size_t* len) {
    return vc_encode_error(b, cap, len, &hdr, &m);
  });
}

Bytes encode(const vc_silhouette& m, const vc_header& hdr) {
  return encode_with(VC_MSG_SILHOUETTE, [&](uint8_t* b, size_t cap, size_t* len) {
    return vc_encode_silhouette(b, cap, len, &hdr, &m);
  });
}

Bytes encode_silhouette_bits(std::span<const uint8_t> bits, uint16_t camera, uint16_t scale, uint16_t width,
                             uint16_t height, const vc_header& hdr) {
  if (bits.size() < (static_cast<size_t>(width) * height + 7) / 8)
    throw ProtoError(-EINVAL, encoding(VC_MSG_SILHOUETTE) + " from a bitset");
  return encode_with(VC_MSG_SILHOUETTE, [&](uint8_t* b, size_t cap, size_t* len) {
    return vc_encode_silhouette_bits(b, cap, len, &hdr, camera, scale, width, height, bits.data());
  });
}

Bytes encode_start(const vc_header& hdr) {
  return encode_with(VC_MSG_START,
                     [&](uint8_t* b, size_t cap, size_t* len) { return vc_encode_start(b, cap, len, &hdr); });
}

Bytes encode_stop(const vc_header& hdr) {
  return encode_with(VC_MSG_STOP,
                     [&](uint8_t* b, size_t cap, size_t* len) { return vc_encode_stop(b, cap, len, &hdr); });
}

Bytes encode_hull_bits(std::span<const uint8_t> bits, size_t nbits, uint32_t grid_id, const vc_header& hdr) {
  if (bits.size() < (nbits + 7) / 8) throw ProtoError(-EINVAL, encoding(VC_MSG_HULL) + " from a bitset");
  return encode_with(VC_MSG_HULL, [&](uint8_t* b, size_t cap, size_t* len) {
    return vc_encode_hull_bits(b, cap, len, &hdr, grid_id, bits.data(), nbits);
  });
}

Bytes encode(const vc_msg& msg) {
  return encode_with(msg.hdr.type,
                     [&](uint8_t* b, size_t cap, size_t* len) { return vc_msg_encode(b, cap, len, &msg); });
}

TriggerDatagram encode_trigger(uint64_t seq, uint64_t t_ns) {
  TriggerDatagram d{};
  check(vc_trigger_dgram_encode(d.data(), seq, t_ns), "encoding the trigger datagram");
  return d;
}

std::optional<TriggerPulse> decode_trigger(std::span<const uint8_t> bytes) {
  TriggerPulse p;
  if (vc_trigger_dgram_decode(bytes.data(), bytes.size(), &p.seq, &p.t_ns) != 0) return std::nullopt;
  return p;
}

vc_rle_info rle_inspect(std::span<const uint8_t> rle) {
  vc_rle_info info{};
  check(vc_rle_inspect(rle.data(), rle.size(), &info), "inspecting RLE");
  return info;
}

}  // namespace vc::proto
