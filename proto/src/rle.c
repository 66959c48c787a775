/* RLE of hull bitsets (proto/SPEC.md, "RLE"). The paper (section 7) run-length encodes each client's
 * partial hull before sending it and ANDs the hulls bitwise on the server; here the AND runs directly
 * on the runs, so the host never expands a partial hull into a bitset.
 *
 * Encoding is the per-frame cost on the edge (128^3..256^3 voxels, a few percent occupied), so it
 * works on 64-bit words: a word that is all 0 (inside an empty run) or all 1 (inside an occupied run)
 * costs one load and compare, and a run end inside a word is found with count-trailing-zeros. Cost is
 * about nbits/64 loads plus one varint per run; there is no per-bit loop. Decoding and the AND are
 * linear in the number of runs (plus, for decoding, a memset per occupied run). On aarch64 the skip over
 * whole empty or occupied words runs on NEON, 64 bytes (8 words) a step; the word holding the run end
 * is then found by the same scalar loop as everywhere, so both scans give the same stream byte for byte
 * (vc_rle_encode_info_portable() keeps the portable scan for the comparison). The host ANDs 3..8
 * partial hulls per frame: vc_rle_and_n does that in one "leapfrog" pass over all of them (see there)
 * instead of a chain of pairwise ANDs that reads and writes every intermediate result.
 *
 * Every reader is strict about the canonical form (see rle.h), so a valid RLE byte string and a
 * bitset correspond one-to-one; the fuzz target checks encode(decode(x)) == x on that basis.
 * Limits: run lengths and totals are 64-bit; a bitset must fit in memory (nbits is a size_t). */
#include "voxcap/rle.h"

#include <errno.h>
#include <string.h>

#include "wire.h"

#if defined(__aarch64__) && defined(__ARM_NEON)
#include <arm_neon.h>
#define VC_RLE_HAVE_NEON 1
#else
#define VC_RLE_HAVE_NEON 0
#endif

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

#if VC_RLE_HAVE_NEON
/* First word index >= w, below full_words - 7 at most, from which a word may differ from `flip`: skips
 * 8 words (64 bytes) a step while all equal flip. The caller's scalar loop finds the exact word. */
static inline size_t skip_words_neon(const bit_source* s, size_t w, uint64_t flip) {
  const uint8x16_t f = vreinterpretq_u8_u64(vdupq_n_u64(flip));
  const uint8_t* b = s->bits;
  for (; w + 8 <= s->full_words; w += 8) {
    const uint8_t* p = b + 8 * w;
    uint8x16_t x = veorq_u8(vld1q_u8(p), f);
    x = vorrq_u8(x, veorq_u8(vld1q_u8(p + 16), f));
    x = vorrq_u8(x, veorq_u8(vld1q_u8(p + 32), f));
    x = vorrq_u8(x, veorq_u8(vld1q_u8(p + 48), f));
    if (vmaxvq_u32(vreinterpretq_u32_u8(x)) != 0) break;
  }
  return w;
}
#endif

/* First bit index >= pos whose value differs from `flip`'s (flip = 0: find a 1; flip = ~0: find a 0),
 * or nbits if none. pos < nbits. `neon`: skip whole words with NEON (a constant at every call). */
static inline size_t find_next(const bit_source* s, size_t pos, uint64_t flip, int neon) {
  size_t w = pos >> 6;
  uint64_t x = (word_at(s, w) ^ flip) & (~UINT64_C(0) << (pos & 63));
  if (!x) {
    ++w;
#if VC_RLE_HAVE_NEON
    if (neon) w = skip_words_neon(s, w, flip);
#else
    (void)neon;
#endif
    /* Skip words that are all empty (flip = 0) or all occupied (flip = ~0), four at a time. */
    const uint8_t* b = s->bits;
    for (; w + 4 <= s->full_words; w += 4) {
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

/* The encoder, with the NEON word skip or without (`neon` a constant: two specialised copies). */
static inline int encode_info(const uint8_t* bits, size_t nbits, uint8_t* out, size_t cap, size_t* out_len,
                              vc_rle_info* info, int neon) {
  if (!out_len || (nbits && !bits) || (cap && !out)) return -EINVAL;
  rle_writer w = {out, cap, 0};
  bit_source s;
  bit_source_init(&s, bits, nbits);
  uint64_t runs = 0, occupied = 0;
  size_t pos = 0;
  while (pos < nbits) {
    size_t end = find_next(&s, pos, 0, neon); /* end of the empty run: the next 1 */
    put_run(&w, end - pos);                   /* only the very first may be 0 */
    runs++;
    pos = end;
    if (pos >= nbits) break;
    end = find_next(&s, pos, ~UINT64_C(0), neon); /* end of the occupied run: the next 0 */
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

int vc_rle_encode_info(const uint8_t* bits, size_t nbits, uint8_t* out, size_t cap, size_t* out_len,
                       vc_rle_info* info) {
  return encode_info(bits, nbits, out, cap, out_len, info, VC_RLE_HAVE_NEON);
}

int vc_rle_encode_info_portable(const uint8_t* bits, size_t nbits, uint8_t* out, size_t cap, size_t* out_len,
                                vc_rle_info* info) {
  return encode_info(bits, nbits, out, cap, out_len, info, 0);
}

const char* vc_rle_encode_impl(void) {
  return VC_RLE_HAVE_NEON ? "neon" : "portable";
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

/* ---- N-way AND ---------------------------------------------------------------------------------- */

/* A stream seen as its sequence of occupied runs: [s, e) is the occupied run that ends after the
 * position the walk is at (it may start further on). Positions are absolute, so moving one stream
 * forward touches no other. Once the stream has no occupied run left, ended is set and s = e = the
 * stream's total. */
typedef struct occ_cursor {
  const uint8_t *p, *end; /* bytes not read yet */
  uint64_t s, e;
  int ended;
} occ_cursor;

/* Reads the next (empty run, occupied run) pair. `first`: at the start of the stream, where the empty
 * run may be 0 (when an occupied run follows). */
static inline int occ_next(occ_cursor* c, int first) {
  if (c->p == c->end) { /* the stream ended with an occupied run (or is empty) */
    c->ended = 1;
    c->s = c->e;
    return 0;
  }
  uint64_t z, o;
  int rc = get_run(&c->p, c->end, &z);
  if (rc) return rc;
  if (z == 0 && (!first || c->p == c->end)) return -EBADMSG; /* only a leading 0, never alone */
  if (z > UINT64_MAX - c->e) return -EBADMSG;                /* total overflows 64 bits */
  if (c->p == c->end) {                                      /* a last, empty run */
    c->ended = 1;
    c->s = c->e = c->e + z;
    return 0;
  }
  if ((rc = get_run(&c->p, c->end, &o))) return rc;
  if (o == 0) return -EBADMSG;
  c->s = c->e + z;
  if (o > UINT64_MAX - c->s) return -EBADMSG;
  c->e = c->s + o;
  return 0;
}

static int occ_init(occ_cursor* c, const uint8_t* p, size_t len) {
  c->p = p;
  c->end = len ? p + len : p; /* no arithmetic on a NULL empty stream */
  c->s = c->e = 0;
  c->ended = 0;
  return occ_next(c, 1);
}

/* Leapfrog: from `pos` (the start of an empty output run), visit the streams round-robin at a
 * candidate position `t`. Each visited stream first skips the occupied runs that end by t; if its next
 * one starts after t, t moves there. The streams counted since the last reset are occupied from t up
 * to occ_end, the least of their run ends; when t moves to occ_end or past it they are dropped and
 * counted again. Once all n are counted, the output's next occupied run is [t, occ_end). The stream
 * that ends it has to move on first, so the next search starts with it. On overlapping partial hulls
 * t only grows towards the latest run start, so each output run costs one visit (two varints) per
 * stream. Runs of the output alternate by construction (an occupied run ends where some stream turns
 * empty), so only the very first empty run can be 0 and the output is canonical without merging. */
int vc_rle_and_n(const uint8_t* const* streams, const size_t* lens, size_t n, uint8_t* out, size_t cap,
                 size_t* out_len) {
  if (!out_len || n == 0 || n > VC_RLE_AND_MAX_STREAMS || !streams || !lens || (cap && !out)) return -EINVAL;
  for (size_t i = 0; i < n; i++)
    if (lens[i] && !streams[i]) return -EINVAL;
  if (n == 1) { /* the chain of one stream is the stream itself */
    vc_rle_info info;
    int rc = vc_rle_inspect(streams[0], lens[0], &info);
    if (rc) return rc;
    *out_len = lens[0];
    if (lens[0] > cap) return -ENOSPC;
    if (lens[0]) memcpy(out, streams[0], lens[0]);
    return 0;
  }
  /* Two streams: the chain is one vc_rle_and, whose simpler loop is as fast or faster (proto_bench). */
  if (n == 2) return vc_rle_and(streams[0], lens[0], streams[1], lens[1], out, cap, out_len);
  occ_cursor cur[VC_RLE_AND_MAX_STREAMS];
  for (size_t i = 0; i < n; i++) {
    int rc = occ_init(&cur[i], streams[i], lens[i]);
    if (rc) return rc;
  }
  rle_writer w = {out, cap, 0};
  uint64_t pos = 0;
  size_t i = 0;
  for (;;) {
    uint64_t t = pos, occ_end = UINT64_MAX;
    size_t agree = 0, i_first_end = i;
    do {
      occ_cursor* c = &cur[i];
      while (c->e <= t && !c->ended) {
        int rc = occ_next(c, 0);
        if (rc) return rc;
      }
      if (c->ended) goto ended; /* no occupied bit at or after t in stream i: none in the output */
      uint64_t nt = c->s > t ? c->s : t;
      if (occ_end <= nt) { /* a counted stream turns empty by nt */
        agree = 0;
        occ_end = UINT64_MAX;
      }
      t = nt;
      if (c->e < occ_end) {
        occ_end = c->e;
        i_first_end = i;
      }
      agree++;
      if (++i == n) i = 0;
    } while (agree < n);
    put_run(&w, t - pos); /* > 0 except when the output starts occupied */
    put_run(&w, occ_end - t);
    pos = occ_end;
    i = i_first_end;
  }
ended:;
  /* The output is empty from pos to the end. Every stream must end where stream i does. */
  uint64_t total = cur[i].e;
  if (total < pos) return -EINVAL;
  if (total > pos) put_run(&w, total - pos);
  for (size_t j = 0; j < n; j++) {
    while (!cur[j].ended) {
      int rc = occ_next(&cur[j], 0);
      if (rc) return rc;
    }
    if (cur[j].e != total) return -EINVAL;
  }
  *out_len = w.len;
  return w.len <= cap ? 0 : -ENOSPC;
}
