/* The streaming decoder: a bounded byte buffer in front of vc_msg_decode.
 *
 * TCP delivers bytes in arbitrary pieces; the decoder buffers them until a whole message is present
 * and hands it out as views into its buffer (no copy of the payload). Memory is bounded by
 * VC_PROTO_HEADER_SIZE + max_payload: the buffer starts small and doubles only while a message needs
 * it. Consumed messages are dropped by moving the unread tail to the front on the next feed; that
 * tail is at most one partial message, so the move is cheap. A fatal (framing) error is sticky:
 * after it the stream cannot be resynchronised, which SPEC.md tells receivers to handle by dropping
 * the connection. */
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sodium.h>

#include "internal.h"
#include "voxcap/auth.h"
#include "voxcap/why.h"

#define DECODER_INITIAL_CAP (64u * 1024u)

struct vc_decoder {
  uint8_t* buf;
  size_t cap;     /* allocated bytes */
  size_t cap_max; /* header + max_payload */
  size_t max_payload;
  size_t rd, wr;      /* unread bytes are buf[rd..wr) */
  uint64_t stream_rd; /* stream offset of buf[rd] */
  int fatal;          /* sticky fatal error, 0 if none */
  bool mac_on;        /* 2.3: every message must carry a valid MAC for mac */
  vc_mac mac;
  vc_proto_diag diag;
};

int vc_decoder_new(size_t max_payload, vc_decoder** out, char* why, size_t why_len) {
  vc_why_clear(why, why_len); /* "" on success */
  if (out) *out = NULL;
  if (!out) {
    vc_why(why, why_len, "decoder: no place for the decoder");
    return -EINVAL;
  }
  if (max_payload == 0) max_payload = VC_PROTO_MAX_PAYLOAD;
  if (max_payload > VC_PROTO_MAX_PAYLOAD) {
    vc_why(why, why_len, "decoder: max_payload %zu is above the protocol's %u bytes", max_payload,
           (unsigned)VC_PROTO_MAX_PAYLOAD);
    return -EINVAL;
  }
  vc_decoder* dec = calloc(1, sizeof *dec);
  if (!dec) goto err_alloc;
  dec->max_payload = max_payload;
  dec->cap_max = VC_PROTO_HEADER_SIZE + max_payload;
  dec->cap = dec->cap_max < DECODER_INITIAL_CAP ? dec->cap_max : DECODER_INITIAL_CAP;
  dec->buf = malloc(dec->cap);
  if (!dec->buf) goto err_buf;
  *out = dec;
  return 0;

err_buf:
  free(dec);
err_alloc:
  vc_why(why, why_len, "decoder: out of memory");
  return -ENOMEM;
}

void vc_decoder_free(vc_decoder* dec) {
  if (!dec) return;
  free(dec->buf);
  sodium_memzero(&dec->mac, sizeof dec->mac);
  free(dec);
}

int vc_decoder_set_max_payload(vc_decoder* dec, size_t max_payload) {
  if (!dec) return -EINVAL;
  if (max_payload == 0) max_payload = VC_PROTO_MAX_PAYLOAD;
  if (max_payload > VC_PROTO_MAX_PAYLOAD) return -EINVAL;
  dec->max_payload = max_payload;
  dec->cap_max = VC_PROTO_HEADER_SIZE + max_payload;
  return 0;
}

int vc_decoder_set_mac(vc_decoder* dec, const vc_mac* rx) {
  if (!dec) return -EINVAL;
  dec->mac_on = rx != NULL;
  if (rx)
    dec->mac = *rx;
  else
    sodium_memzero(&dec->mac, sizeof dec->mac);
  return 0;
}

int vc_decoder_feed(vc_decoder* dec, const uint8_t* data, size_t len, size_t* consumed) {
  if (!dec || (len && !data) || !consumed) return -EINVAL;
  *consumed = 0;
  if (dec->fatal) return dec->fatal;
  if (len == 0) return 0;
  if (dec->rd > 0) { /* drop what next() has handed out; its views expire now */
    memmove(dec->buf, dec->buf + dec->rd, dec->wr - dec->rd);
    dec->wr -= dec->rd;
    dec->rd = 0;
  }
  if (dec->cap - dec->wr < len && dec->cap < dec->cap_max) {
    size_t want = dec->wr + len;
    size_t grown = dec->cap * 2 > want ? dec->cap * 2 : want;
    if (grown > dec->cap_max) grown = dec->cap_max;
    uint8_t* nb = realloc(dec->buf, grown);
    if (!nb) return -ENOMEM;
    dec->buf = nb;
    dec->cap = grown;
  }
  size_t n = dec->cap - dec->wr < len ? dec->cap - dec->wr : len;
  memcpy(dec->buf + dec->wr, data, n);
  dec->wr += n;
  *consumed = n;
  return 0;
}

int vc_decoder_next(vc_decoder* dec, vc_msg* out) {
  if (!dec || !out) return -EINVAL;
  if (dec->fatal) return dec->fatal;
  size_t used = 0;
  vc_proto_diag diag;
  int rc = vc_msg_decode_mac(dec->buf + dec->rd, dec->wr - dec->rd, dec->max_payload,
                             dec->mac_on ? &dec->mac : NULL, out, &used, &diag);
  if (rc < 0) {
    diag.offset = dec->stream_rd;
    dec->diag = diag;
    if (vc_proto_error_is_fatal(rc)) dec->fatal = rc;
  }
  dec->rd += used;
  dec->stream_rd += used;
  return rc;
}

int vc_decoder_finish(vc_decoder* dec) {
  if (!dec) return -EINVAL;
  if (dec->fatal) return dec->fatal;
  size_t pending = dec->wr - dec->rd;
  if (pending == 0) return 0;
  dec->diag.offset = dec->stream_rd;
  if (pending >= VC_PROTO_HEADER_SIZE) { /* next() validated this header already */
    const uint8_t* h = dec->buf + dec->rd;
    uint16_t type = (uint16_t)(h[6] | h[7] << 8);
    uint32_t plen = (uint32_t)h[12] | (uint32_t)h[13] << 8 | (uint32_t)h[14] << 16 | (uint32_t)h[15] << 24;
    const char* name = vc_msg_type_name(type);
    dec->fatal = vc_diag_set(&dec->diag, VC_PROTO_EEOF, "stream ended %zu of %zu bytes into a %s message",
                             pending, (size_t)VC_PROTO_HEADER_SIZE + plen, name ? name : "unknown-type");
  } else {
    dec->fatal =
        vc_diag_set(&dec->diag, VC_PROTO_EEOF, "stream ended %zu bytes into a message header", pending);
  }
  return dec->fatal;
}

const vc_proto_diag* vc_decoder_diag(const vc_decoder* dec) {
  return &dec->diag;
}

uint64_t vc_decoder_offset(const vc_decoder* dec) {
  return dec->stream_rd;
}

size_t vc_decoder_pending(const vc_decoder* dec) {
  return dec->wr - dec->rd;
}
