/* RLE of hull bitsets (proto/SPEC.md, "RLE"). The paper (section 7) run-length encodes each client's
 * partial hull before sending it and ANDs the hulls bitwise on the server; here the AND runs directly
 * on the runs, so the host never expands a partial hull into a bitset.
 *
 * Encoding is the per-frame cost on the edge (128^3..256^3 voxels, a few percent occupied), so it
 * works on 64-bit words: a word that is all 0 (inside an empty run) or all 1 (inside an occupied run)
 * costs one load and compare, and a run end inside a word is found with count-trailing-zeros. Cost is
 * about nbits/64 loads plus one varint per run; there is no per-bit loop. Decoding and the AND are
 * linear in the number of runs (plus, for decoding, a memset per occupied run).
 *
 * Every reader is strict about the canonical form (see rle.h), so a valid RLE byte string and a
 * bitset correspond one-to-one; the fuzz target checks encode(decode(x)) == x on that basis.
 * Limits: run lengths and totals are 64-bit; a bitset must fit in memory (nbits is a size_t). */
#include "voxcap/rle.h"

#include <errno.h>
#include <string.h>

#include "wire.h"

/* ---- varints ---------------------------------------------------------------------------------- */

#define VARINT_MAX_BYTES 10

typedef struct rle_writer {
  uint8_t* out;
  size_t cap;
  size_t len; /* bytes needed so far; may exceed cap, then nothing more is written */
} rle_writer;

static void put_run_slow(rle_writer* w, uint64_t v) {
  uint8_t tmp[VARINT_MAX_BYTES];
  size_t n = 0;
  while (v >= 0x80) {
    tmp[n++] = (uint8_t)(v | 0x80);
    v >>= 7;
  }
  tmp[n++] = (uint8_t)v;
  if (w->len <= w->cap && n <= w->cap - w->len) memcpy(w->out + w->len, tmp, n);
  w->len += n;
}

static inline void put_run(rle_writer* w, uint64_t v) {
  if (w->cap >= VARINT_MAX_BYTES && w->len <= w->cap - VARINT_MAX_BYTES) {
    uint8_t* p = w->out + w->len;
    while (v >= 0x80) {
      *p++ = (uint8_t)(v | 0x80);
      v >>= 7;
    }
    *p++ = (uint8_t)v;
    w->len = (size_t)(p - w->out);
    return;
  }
  put_run_slow(w, v);
}

/* Strict LEB128 read: at most 10 bytes, value < 2^64, no redundant trailing 0x00 byte. */
static inline int get_run(const uint8_t** pp, const uint8_t* end, uint64_t* v) {
  const uint8_t* p = *pp;
  if (p < end && *p < 0x80) { /* the common case: a run shorter than 128 */
    *v = *p;
    *pp = p + 1;
    return 0;
  }
  uint64_t r = 0;
  for (unsigned i = 0; i < VARINT_MAX_BYTES; i++) {
    if (p == end) return -EBADMSG; /* truncated varint */
    uint8_t b = *p++;
    if (i == VARINT_MAX_BYTES - 1 && b > 1) return -EBADMSG; /* would overflow 64 bits */
    r |= (uint64_t)(b & 0x7F) << (7 * i);
    if (!(b & 0x80)) {
      if (b == 0 && i > 0) return -EBADMSG; /* overlong: redundant zero byte */
      *v = r;
      *pp = p;
      return 0;
    }
  }
  return -EBADMSG; /* not reached: the 10th byte has no continuation bit */
}

/* ---- word access to the bitset ------------------------------------------------------------------ */

typedef struct bit_source {
  const uint8_t* bits;
  size_t nbits;
  size_t full_words; /* words entirely inside nbits */
  size_t nwords;     /* full_words, plus one if a partial tail word exists */
  uint64_t tail;     /* the partial tail word, bits past nbits cleared */
} bit_source;

static void bit_source_init(bit_source* s, const uint8_t* bits, size_t nbits) {
  s->bits = bits;
  s->nbits = nbits;
  s->full_words = nbits / 64;
  s->nwords = s->full_words + (nbits % 64 != 0);
  s->tail = 0;
  if (nbits % 64) {
    size_t tail_bits = nbits % 64;
    size_t tail_bytes = (tail_bits + 7) / 8;
    uint8_t buf[8] = {0};
    memcpy(buf, bits + s->full_words * 8, tail_bytes);
    s->tail = vc_ld64(buf) & ((UINT64_C(1) << tail_bits) - 1);
  }
}

static inline uint64_t word_at(const bit_source* s, size_t w) {
  return w < s->full_words ? vc_ld64(s->bits + 8 * w) : s->tail;
}

/* First bit index >= pos whose value differs from `flip`'s (flip = 0: find a 1; flip = ~0: find a 0),
 * or nbits if none. pos < nbits. */
static inline size_t find_next(const bit_source* s, size_t pos, uint64_t flip) {
  size_t w = pos >> 6;
  uint64_t x = (word_at(s, w) ^ flip) & (~UINT64_C(0) << (pos & 63));
  if (!x) {
    /* Skip words that are all empty (flip = 0) or all occupied (flip = ~0), four at a time. */
    const uint8_t* b = s->bits;
    for (++w; w + 4 <= s->full_words; w += 4) {
      uint64_t a0 = vc_ld64(b + 8 * w) ^ flip, a1 = vc_ld64(b + 8 * w + 8) ^ flip;
      uint64_t a2 = vc_ld64(b + 8 * w + 16) ^ flip, a3 = vc_ld64(b + 8 * w + 24) ^ flip;
      if (a0 | a1 | a2 | a3) break;
    }
    for (; w < s->nwords; ++w) {
      x = word_at(s, w) ^ flip;
      if (x) break;
    }
    if (!x) return s->nbits;
  }
  size_t r = (w << 6) + (size_t)__builtin_ctzll(x);
  return r < s->nbits ? r : s->nbits;
}

/* ---- public functions ------------------------------------------------------------------------- */

size_t vc_rle_max_encoded_size(size_t nbits) {
  if (nbits == 0) return 0;
  return nbits == SIZE_MAX ? SIZE_MAX : nbits + 1;
}

int vc_rle_encode_info(const uint8_t* bits, size_t nbits, uint8_t* out, size_t cap, size_t* out_len,
                       vc_rle_info* info) {
  if (!out_len || (nbits && !bits) || (cap && !out)) return -EINVAL;
  rle_writer w = {out, cap, 0};
  bit_source s;
  bit_source_init(&s, bits, nbits);
  uint64_t runs = 0, occupied = 0;
  size_t pos = 0;
  while (pos < nbits) {
    size_t end = find_next(&s, pos, 0); /* end of the empty run: the next 1 */
    put_run(&w, end - pos);             /* only the very first may be 0 */
    runs++;
    pos = end;
    if (pos >= nbits) break;
    end = find_next(&s, pos, ~UINT64_C(0)); /* end of the occupied run: the next 0 */
    put_run(&w, end - pos);
    runs++;
    occupied += end - pos;
    pos = end;
  }
  *out_len = w.len;
  if (info) {
    info->total = nbits;
    info->occupied = occupied;
    info->runs = runs;
  }
  return w.len <= cap ? 0 : -ENOSPC;
}

int vc_rle_encode(const uint8_t* bits, size_t nbits, uint8_t* out, size_t cap, size_t* out_len) {
  return vc_rle_encode_info(bits, nbits, out, cap, out_len, NULL);
}

/* Sets bits [pos, pos + n) of b; n >= 1. */
static void set_range(uint8_t* b, size_t pos, size_t n) {
  size_t end = pos + n;
  size_t b0 = pos >> 3, b1 = end >> 3;
  unsigned lo = (unsigned)(pos & 7), hi = (unsigned)(end & 7);
  if (b0 == b1) {
    b[b0] |= (uint8_t)(((1u << hi) - 1u) & ~((1u << lo) - 1u));
    return;
  }
  if (lo) {
    b[b0] |= (uint8_t)(0xFFu << lo);
    b0++;
  }
  memset(b + b0, 0xFF, b1 - b0);
  if (hi) b[b1] |= (uint8_t)((1u << hi) - 1u);
}

int vc_rle_decode(const uint8_t* rle, size_t len, uint8_t* bits, size_t nbits) {
  if ((len && !rle) || (nbits && !bits)) return -EINVAL;
  if (nbits) memset(bits, 0, nbits / 8 + (nbits % 8 != 0));
  if (len == 0) return nbits == 0 ? 0 : -EINVAL;
  const uint8_t *p = rle, *end = rle + len;
  size_t pos = 0;
  int occupied = 0, first = 1;
  while (p < end) {
    uint64_t v;
    int rc = get_run(&p, end, &v);
    if (rc) return rc;
    if (v == 0 && !(first && p < end)) return -EBADMSG; /* non-canonical zero run */
    if (v > nbits - pos) return -EINVAL;                /* runs overshoot nbits */
    if (occupied) set_range(bits, pos, (size_t)v);
    pos += (size_t)v;
    occupied ^= 1;
    first = 0;
  }
  return pos == nbits ? 0 : -EINVAL;
}

int vc_rle_inspect(const uint8_t* rle, size_t len, vc_rle_info* info) {
  if (!info || (len && !rle)) return -EINVAL;
  uint64_t total = 0, occupied = 0, runs = 0;
  const uint8_t *p = rle, *end = len ? rle + len : rle;
  while (p < end) {
    uint64_t v;
    int rc = get_run(&p, end, &v);
    if (rc) return rc;
    if (v == 0 && !(runs == 0 && p < end)) return -EBADMSG;
    if (v > UINT64_MAX - total) return -EBADMSG; /* total overflows 64 bits */
    total += v;
    if (runs & 1) occupied += v;
    runs++;
  }
  info->total = total;
  info->occupied = occupied;
  info->runs = runs;
  return 0;
}

int vc_rle_popcount(const uint8_t* rle, size_t len, uint64_t* occupied, uint64_t* total) {
  vc_rle_info info;
  int rc = vc_rle_inspect(rle, len, &info);
  if (rc) return rc;
  if (occupied) *occupied = info.occupied;
  if (total) *total = info.total;
  return 0;
}

/* A reader positioned inside one run of an RLE stream. */
typedef struct run_cursor {
  const uint8_t *p, *end;
  uint64_t rem; /* bits left in the current run (>= 1 unless done) */
  int state;    /* 0 empty, 1 occupied */
  int done;
} run_cursor;

static int cursor_next(run_cursor* c) {
  if (c->p == c->end) {
    c->done = 1;
    c->rem = 0;
    return 0;
  }
  uint64_t v;
  int rc = get_run(&c->p, c->end, &v);
  if (rc) return rc;
  if (v == 0) return -EBADMSG; /* only the first run may be 0 */
  c->state ^= 1;
  c->rem = v;
  return 0;
}

static int cursor_init(run_cursor* c, const uint8_t* p, size_t len) {
  c->p = p;
  c->end = len ? p + len : p; /* no arithmetic on a NULL empty stream */
  c->state = 0;
  c->done = 0;
  c->rem = 0;
  if (len == 0) {
    c->done = 1;
    return 0;
  }
  int rc = get_run(&c->p, c->end, &c->rem);
  if (rc) return rc;
  if (c->rem == 0) {
    if (c->p == c->end) return -EBADMSG; /* a lone 0 run */
    return cursor_next(c);
  }
  return 0;
}

int vc_rle_and(const uint8_t* a, size_t alen, const uint8_t* b, size_t blen, uint8_t* out, size_t cap,
               size_t* out_len) {
  if (!out_len || (alen && !a) || (blen && !b) || (cap && !out)) return -EINVAL;
  run_cursor ca, cb;
  int rc = cursor_init(&ca, a, alen);
  if (!rc) rc = cursor_init(&cb, b, blen);
  if (rc) return rc;
  rle_writer w = {out, cap, 0};
  int out_state = 0; /* state of the output run being accumulated (starts empty) */
  uint64_t acc = 0;  /* its length so far */
  uint64_t pos = 0;  /* bits consumed from both inputs */
  while (!ca.done && !cb.done) {
    uint64_t step = ca.rem < cb.rem ? ca.rem : cb.rem;
    if (pos + step < pos) return -EBADMSG;
    pos += step;
    int s = ca.state & cb.state;
    if (s == out_state) {
      acc += step;
    } else {
      put_run(&w, acc); /* 0 only for a leading empty run */
      out_state = s;
      acc = step;
    }
    ca.rem -= step;
    cb.rem -= step;
    if (ca.rem == 0 && (rc = cursor_next(&ca))) return rc;
    if (cb.rem == 0 && (rc = cursor_next(&cb))) return rc;
  }
  if (!ca.done || !cb.done) return -EINVAL; /* different totals */
  if (acc) put_run(&w, acc);
  *out_len = w.len;
  return w.len <= cap ? 0 : -ENOSPC;
}
