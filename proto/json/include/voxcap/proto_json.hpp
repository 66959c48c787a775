// JSON views of protocol messages, shared by `voxcap proto dump`, the test-vector generator and the
// vector tests, so all three name every field exactly as proto/SPEC.md does. C++20, nlohmann-json.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <limits>
#include <span>
#include <string>

#include <nlohmann/json.hpp>

#include "voxcap/proto.h"

namespace vc::proto {

using Json = nlohmann::ordered_json;

struct JsonOptions {
  // Bytes of HULL RLE / unknown payloads rendered as hex; the rest is cut ("rle_truncated": true).
  size_t max_hex_bytes = std::numeric_limits<size_t>::max();
  // Number of HULL runs listed in "runs" (0: no list).
  size_t max_runs = 0;
};

// {"magic", "version_major", "version_minor", "type", "flags", "node_id", "payload_len", "seq",
//  "t_trigger_ns", "payload_crc", "header_crc"}
Json header_to_json(const vc_header& hdr);

// {"type": "HULL" | "UNKNOWN", "header": {...}, "known": bool, "ignored_bytes": n, "body": {...}}.
// The body has one key per SPEC.md field (numbers as on the wire), plus "<field>_name" strings next
// to enumerations. For unknown types the body is {"payload": hex}. msg.payload may be NULL (a message
// built for encoding): then only known bodies are rendered.
Json msg_to_json(const vc_msg& msg, const JsonOptions& opt = {});

// {"code": "VC_PROTO_EMAGIC", "value": -1001, "fatal": true, "message": "bad magic"} and, when
// with_detail, "detail": the decoder's explanation.
Json error_to_json(const vc_proto_diag& diag, bool with_detail);

// Decodes a whole byte stream with a vc_decoder, feeding it in chunks whose sizes `chunker` picks
// (called with the bytes left; returns 1..left; nullptr: everything at once), and returns the events:
// [{"offset": n, "message": msg_to_json(...)} | {"offset": n, "error": error_to_json(...)}], ending
// at the first fatal error or at the end of the stream (vc_decoder_finish). A non-fatal error event
// also carries "type" (the rejected message's type name or number).
Json decode_events(std::span<const uint8_t> bytes, size_t max_payload,
                   const std::function<size_t(size_t)>& chunker = nullptr, bool with_detail = false,
                   const JsonOptions& opt = {});

// `voxcap proto dump`: reads a capture (a raw concatenation of messages, as a TCP stream carries
// them) from `in` and prints one block per message (text) or one JSON object per line (json).
struct DumpOptions {
  bool json = false;
  size_t max_payload = 0;  // 0: VC_PROTO_MAX_PAYLOAD
  JsonOptions fields{64, 16};
  bool valid(std::string* why) const;
};
struct DumpResult {
  size_t messages = 0;  // messages decoded (known or not)
  size_t rejected = 0;  // messages rejected with a non-fatal error
  int fatal = 0;        // the fatal error that ended the stream, 0 if none
  uint64_t fatal_offset = 0;
  std::string fatal_detail;
  bool ok() const { return rejected == 0 && fatal == 0; }
};
DumpResult dump(std::istream& in, std::ostream& out, const DumpOptions& opt);

// Renders one event of decode_events as the text block `dump` prints.
std::string event_to_text(const Json& event);

}  // namespace vc::proto
