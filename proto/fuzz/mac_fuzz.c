/* libFuzzer target: the 2.3 authenticated framing (auth.h) on arbitrary bytes.
 *
 * Three properties per input:
 *  1. Decoded as a receiver on an authenticated connection decodes (a fixed session key, counter 0),
 *     fed in pseudo-random chunks, the input never crashes the decoder and every message it accepts
 *     advanced the expected counter by exactly one: nobody without the key gets a message through
 *     (the fuzzer does not know the key, so accepted messages can only come from the seeded stream).
 *  2. The input cut into frames of arbitrary type and payload and sealed with the sender's state
 *     decodes, in order, to exactly those frames (seal and open are inverse, any payload, any size);
 *     the same stream with one byte of a trailer or body changed (CRCs repaired) is never accepted
 *     whole: at least one message is rejected with VC_PROTO_EMAC.
 *  3. The input as a trigger datagram: vc_trigger_dgram_decode_mac accepts nothing without the key. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "voxcap/auth.h"
#include "voxcap/crc32c.h"
#include "voxcap/proto.h"

static uint8_t g_stream[1u << 20];

static vc_mac fixed_mac(void) {
  vc_mac m;
  for (int i = 0; i < VC_AUTH_KEY_SIZE; i++) m.key[i] = (uint8_t)(0xA5 ^ i);
  m.counter = 0;
  return m;
}

static uint64_t xorshift(uint64_t* s) {
  *s ^= *s << 13;
  *s ^= *s >> 7;
  *s ^= *s << 17;
  return *s;
}

/* Feeds stream in chunks; returns the messages that passed the MAC check (whether or not their body
 * then parsed), *emac the VC_PROTO_EMAC count. */
static size_t decode_all(const uint8_t* data, size_t size, const vc_mac* rx, uint64_t seed, size_t* emac) {
  vc_decoder* dec = NULL;
  if (vc_decoder_new(0, &dec, NULL, 0) < 0) abort();
  vc_decoder_set_mac(dec, rx);
  size_t accepted = 0, off = 0;
  *emac = 0;
  uint64_t s = seed | 1;
  while (off < size) {
    size_t want = 1 + (size_t)(xorshift(&s) % 4096), used = 0;
    if (want > size - off) want = size - off;
    if (vc_decoder_feed(dec, data + off, want, &used) < 0) break;
    off += used;
    vc_msg m;
    int rc;
    while ((rc = vc_decoder_next(dec, &m)) != 0) {
      if (rc < 0 && vc_proto_error_is_fatal(rc)) goto out;
      if (rc == VC_PROTO_EMAC) (*emac)++;
      if (rc == 1 || (rc != VC_PROTO_EMAC && rc != VC_PROTO_EREPLAY && rc != VC_PROTO_EORDER)) accepted++;
    }
    if (used == 0 && want) break;
  }
out:
  vc_decoder_free(dec);
  return accepted;
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  vc_mac rx = fixed_mac(), tx = fixed_mac();
  size_t emac = 0;
  uint64_t seed = size;
  for (size_t i = 0; i < size && i < 8; i++) seed = seed * 131 + data[i];
  /* 1: arbitrary bytes on an authenticated connection */
  if (decode_all(data, size, &rx, seed, &emac) != 0) abort(); /* no key, no message */

  /* 2: frames cut from the input, sealed */
  size_t n = 0, frames = 0, in = 0;
  while (in + 3 <= size && frames < 64) {
    uint16_t type = (uint16_t)(data[in] | data[in + 1] << 8);
    size_t plen = data[in + 2] * 7u;
    in += 3;
    if (plen > size - in) plen = size - in;
    vc_header h = {.version_major = VC_PROTO_VERSION_MAJOR, .version_minor = 200, .type = type};
    size_t len = 0, sealed = 0;
    if (vc_frame_encode(g_stream + n, sizeof g_stream - n, &len, &h, data + in, plen) < 0) break;
    if (vc_mac_seal(&tx, g_stream + n, len, sizeof g_stream - n, &sealed) < 0) break;
    n += sealed;
    in += plen;
    frames++;
  }
  vc_mac rx2 = fixed_mac();
  if (decode_all(g_stream, n, &rx2, seed, &emac) != frames) abort(); /* newer minor: every frame decodes */
  if (n > VC_PROTO_HEADER_SIZE + VC_AUTH_TRAILER_SIZE) {
    size_t at = VC_PROTO_HEADER_SIZE + (size_t)(seed % (n - VC_PROTO_HEADER_SIZE));
    /* only bytes of the first frame's body or trailer; repair that frame's CRCs */
    uint32_t plen0 = (uint32_t)g_stream[12] | (uint32_t)g_stream[13] << 8 | (uint32_t)g_stream[14] << 16 |
                     (uint32_t)g_stream[15] << 24;
    at = VC_PROTO_HEADER_SIZE + (at % plen0);
    g_stream[at] ^= (uint8_t)(1u << (seed % 8));
    uint32_t pc = vc_crc32c(0, g_stream + VC_PROTO_HEADER_SIZE, plen0);
    for (int i = 0; i < 4; i++) g_stream[32 + i] = (uint8_t)(pc >> (8 * i));
    uint32_t hc = vc_crc32c(0, g_stream, 36);
    for (int i = 0; i < 4; i++) g_stream[36 + i] = (uint8_t)(hc >> (8 * i));
    vc_mac rx3 = fixed_mac();
    size_t ok = decode_all(g_stream, n, &rx3, seed, &emac);
    if (emac == 0 || ok == frames) abort();
  }

  /* 3: the trigger datagram */
  vc_mac trx = fixed_mac();
  uint8_t key[VC_AUTH_KEY_SIZE] = {0};
  vc_auth_trigger_key(key, &trx);
  if (size == VC_TRIGGER_DGRAM_MAC_SIZE && vc_trigger_dgram_decode_mac(data, size, &trx, NULL, NULL) == 0) {
    /* only possible if the fuzzer found a BLAKE2b-128 tag for the zero key: impossible in practice */
    abort();
  }
  return 0;
}
