/* libFuzzer target: the streaming decoder on arbitrary bytes.
 *
 * Half of the inputs have their CRCs repaired frame by frame before decoding (a random mutation
 * almost always breaks a CRC, which would stop the decoder before any payload parser runs); the other
 * half are decoded as they are. Each input is decoded twice, fed whole and fed in pseudo-random chunks
 * (seeded from the input), and must give the same sequence of messages and errors: chunking never
 * changes the result. Every message decoded at this library's exact version must re-encode to the
 * very bytes it was decoded from (decode is exact, encode is its inverse). A quarter of the inputs are
 * decoded as the host decodes a stranger: VC_PROTO_MAX_HELLO_PAYLOAD until the first message, the full
 * maximum after it (vc_decoder_set_max_payload). ASan/UBSan catch over-reads and undefined behaviour;
 * any property violation aborts. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "voxcap/crc32c.h"
#include "voxcap/proto.h"

#define MAX_EVENTS 1024

typedef struct event {
  int rc;
  uint64_t offset;
  uint16_t type;
  uint32_t payload_len;
} event;

typedef struct trace {
  event ev[MAX_EVENTS];
  size_t n; /* events seen, may exceed MAX_EVENTS (then only the first are kept) */
} trace;

static uint8_t g_reencoded[VC_PROTO_HEADER_SIZE + VC_PROTO_MAX_PAYLOAD];

static uint32_t ld32(const uint8_t* p) {
  return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void st32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; i++) p[i] = (uint8_t)(v >> (8 * i));
}

static uint64_t xorshift(uint64_t* s) {
  *s ^= *s << 13;
  *s ^= *s >> 7;
  *s ^= *s << 17;
  return *s;
}

/* Rewrites payload_crc and header_crc of every complete frame, walking the stream by payload_len. */
static void repair_crcs(uint8_t* b, size_t n) {
  size_t p = 0;
  while (n - p >= VC_PROTO_HEADER_SIZE) {
    uint32_t plen = ld32(b + p + 12);
    size_t avail = n - p - VC_PROTO_HEADER_SIZE;
    if (plen <= avail) st32(b + p + 32, vc_crc32c(0, b + p + VC_PROTO_HEADER_SIZE, plen));
    st32(b + p + 36, vc_crc32c(0, b + p, 36));
    if (plen > avail) break;
    p += VC_PROTO_HEADER_SIZE + plen;
  }
}

static void record(trace* t, int rc, uint64_t offset, const vc_msg* m) {
  if (t->n < MAX_EVENTS) {
    event* e = &t->ev[t->n];
    e->rc = rc;
    e->offset = offset;
    e->type = rc > 0 || !vc_proto_error_is_fatal(rc) ? m->hdr.type : 0;
    e->payload_len = rc > 0 ? m->hdr.payload_len : 0;
  }
  t->n++;
}

static void check_reencode(const vc_msg* m) {
  if (!m->known || m->hdr.version_minor != VC_PROTO_VERSION_MINOR) return;
  size_t len = 0;
  int rc = vc_msg_encode(g_reencoded, sizeof g_reencoded, &len, m);
  if (rc != 0) abort(); /* the decoder accepted what the encoder refuses */
  if (len != VC_PROTO_HEADER_SIZE + (size_t)m->hdr.payload_len) abort();
  if (memcmp(g_reencoded, m->payload - VC_PROTO_HEADER_SIZE, len) != 0) abort();
}

/* Decodes b[0..n) with chunk sizes from `seed` (0: one chunk); with `raise`, max_payload goes to the
 * protocol's maximum after the first message. */
static void decode(const uint8_t* b, size_t n, size_t max_payload, int raise, uint64_t seed, trace* t,
                   vc_msg* m) {
  vc_decoder* dec = NULL;
  if (vc_decoder_new(max_payload, &dec, NULL, 0) < 0) abort();
  t->n = 0;
  size_t pos = 0;
  int fatal = 0;
  while (pos < n && !fatal) {
    size_t chunk = n - pos;
    if (seed) chunk = 1 + (size_t)(xorshift(&seed) % (chunk < 97 ? chunk : 97));
    for (size_t off = 0; off < chunk && !fatal;) {
      size_t used = 0;
      if (vc_decoder_feed(dec, b + pos + off, chunk - off, &used) < 0) abort(); /* fatal is seen by next */
      off += used;
      for (;;) {
        uint64_t at = vc_decoder_offset(dec);
        int rc = vc_decoder_next(dec, m);
        if (rc == 0) break;
        record(t, rc, rc < 0 ? vc_decoder_diag(dec)->offset : at, m);
        if (rc > 0) check_reencode(m);
        if (rc > 0 && raise) {
          if (vc_decoder_set_max_payload(dec, 0) != 0) abort();
          raise = 0;
        }
        if (rc < 0 && vc_proto_error_is_fatal(rc)) {
          fatal = 1;
          break;
        }
      }
    }
    pos += chunk;
  }
  if (!fatal) {
    int rc = vc_decoder_finish(dec);
    if (rc) record(t, rc, vc_decoder_diag(dec)->offset, m);
  }
  vc_decoder_free(dec);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static trace whole, chunked;
  static vc_msg msg;
  uint64_t seed = vc_crc32c(0, data, size) | UINT64_C(1) << 40;
  uint8_t* b = malloc(size ? size : 1);
  if (!b) return 0;
  if (size) memcpy(b, data, size);
  if (seed & 1) repair_crcs(b, size);
  size_t max_payload = (seed & 2) ? 1024 : 0;
  int raise = (seed & 6) == 6; /* the host's pre-HELLO limit, raised after the first message */
  if (raise) max_payload = VC_PROTO_MAX_HELLO_PAYLOAD;
  decode(b, size, max_payload, raise, 0, &whole, &msg);
  decode(b, size, max_payload, raise, seed, &chunked, &msg);
  if (whole.n != chunked.n) abort();
  size_t kept = whole.n < MAX_EVENTS ? whole.n : MAX_EVENTS;
  for (size_t i = 0; i < kept; i++) {
    const event *a = &whole.ev[i], *c = &chunked.ev[i];
    if (a->rc != c->rc || a->offset != c->offset || a->type != c->type || a->payload_len != c->payload_len)
      abort();
  }
  free(b);
  return 0;
}
