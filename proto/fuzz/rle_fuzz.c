/* libFuzzer target: the RLE functions on arbitrary bytes.
 *
 * Input: byte 0 picks a split; the bytes after it are RLE stream A (up to the split) and stream B (the
 * rest). Checked properties, any violation aborts:
 *  - inspect, popcount and decode agree on whether A is valid;
 *  - a valid A of at most 2^18 bits decodes, re-encodes to exactly A (canonical form is unique),
 *    its popcount equals the decoded bit count, and decoding with one bit more or less fails;
 *  - AND of A with a second bitset of the same size (A's bits XOR a pattern from B) equals the RLE of
 *    the bitwise AND; AND of A and B succeeds iff both are valid with equal totals;
 *  - vc_rle_and_n against the chain of vc_rle_and: on the raw bytes cut into 1..8 streams (same result,
 *    same error when every piece is valid, both fail otherwise; ENOSPC at the same needed size), and on
 *    A with up to 7 more bitsets of its size (A's bits XOR rotations of B), where it must also equal the
 *    RLE of the bitwise AND of all of them. */
#include <errno.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "voxcap/rle.h"

#define MAX_BITS (1u << 18)

/* Set bits of a decoded bitset (padding bits are 0 after vc_rle_decode). */
static uint64_t count_bits(const uint8_t* b, size_t nbits) {
  uint64_t c = 0;
  for (size_t i = 0; i < (nbits + 7) / 8; i++) c += (uint64_t)__builtin_popcount(b[i]);
  return c;
}

static uint8_t* encode_alloc(const uint8_t* bits, size_t nbits, size_t* len) {
  size_t cap = vc_rle_max_encoded_size(nbits);
  uint8_t* out = malloc(cap ? cap : 1);
  if (!out) abort();
  if (vc_rle_encode(bits, nbits, out, cap, len) != 0) abort();
  return out;
}

#define MAX_STREAMS 8

/* The chain vc_rle_and(...vc_rle_and(s0, s1)..., s[n-1]), `cap` bytes for the last step, ample room
 * before it: what vc_rle_and_n must match. Returns its code; *out_len as vc_rle_and sets it. */
static int and_chain(const uint8_t* const* s, const size_t* lens, size_t n, uint8_t* out, size_t cap,
                     size_t* out_len) {
  if (n == 1) {
    vc_rle_info info;
    int rc = vc_rle_inspect(s[0], lens[0], &info);
    if (rc) return rc;
    *out_len = lens[0];
    if (lens[0] > cap) return -ENOSPC;
    if (lens[0]) memcpy(out, s[0], lens[0]);
    return 0;
  }
  const uint8_t* acc = s[0];
  size_t acc_len = lens[0];
  uint8_t* bufs[2] = {NULL, NULL};
  int rc = 0;
  for (size_t i = 1; i < n && rc == 0; i++) {
    uint8_t* dst = out;
    size_t room = cap;
    if (i + 1 < n) { /* intermediate: runs(and) <= runs(acc) + runs(s[i]), 10 bytes per run at most */
      room = 10 * (acc_len + lens[i]) + 16;
      free(bufs[i & 1]);
      dst = bufs[i & 1] = malloc(room);
      if (!dst) abort();
    }
    size_t len = 0;
    rc = vc_rle_and(acc, acc_len, s[i], lens[i], dst, room, &len);
    if (rc == 0 || (rc == -ENOSPC && i + 1 == n)) *out_len = len;
    acc = dst;
    acc_len = len;
  }
  free(bufs[0]);
  free(bufs[1]);
  return rc;
}

/* vc_rle_and_n and the chain on the same streams and cap: identical results. `all_valid`: every
 * stream passed vc_rle_inspect, so the error codes must match exactly; otherwise both must fail. */
static void cross_check(const uint8_t* const* s, const size_t* lens, size_t n, size_t cap, int all_valid) {
  uint8_t* a = malloc(cap ? cap : 1);
  uint8_t* b = malloc(cap ? cap : 1);
  if (!a || !b) abort();
  size_t alen = (size_t)-1, blen = (size_t)-1;
  int ra = vc_rle_and_n(s, lens, n, a, cap, &alen);
  int rb = and_chain(s, lens, n, b, cap, &blen);
  if (all_valid && ra != rb) abort();
  /* Both walk every byte before deciding on ENOSPC, so a malformed piece is always an error. */
  if (!all_valid && ((ra != -EINVAL && ra != -EBADMSG) || (rb != -EINVAL && rb != -EBADMSG))) abort();
  if (ra != 0 && ra != -EINVAL && ra != -EBADMSG && ra != -ENOSPC) abort();
  if ((ra == 0 || ra == -ENOSPC) && ra == rb && alen != blen) abort();
  if (ra == 0 && ra == rb && alen && memcmp(a, b, alen) != 0) abort();
  free(a);
  free(b);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  size_t split = 1 + (size - 1) * data[0] / 255;
  const uint8_t *a = data + 1, *b = data + split;
  size_t alen = split - 1, blen = size - split;

  vc_rle_info ia, ib;
  int ra = vc_rle_inspect(a, alen, &ia), rb = vc_rle_inspect(b, blen, &ib);
  uint64_t occ = 0, total = 0;
  if (vc_rle_popcount(a, alen, &occ, &total) != ra) abort();
  if (ra == 0 && (occ != ia.occupied || total != ia.total)) abort();
  if (ra != 0 && ra != -EBADMSG) abort();

  /* AND of the raw streams: defined exactly when both are valid with the same total. */
  size_t out_cap = 2 * (alen + blen) + 16, out_len = 0;
  uint8_t* out = malloc(out_cap);
  if (!out) abort();
  int rand_ = vc_rle_and(a, alen, b, blen, out, out_cap, &out_len);
  if (ra == 0 && rb == 0 && ia.total == ib.total && rand_ != 0 && rand_ != -ENOSPC) abort();
  if ((ra != 0 || rb != 0) && rand_ == 0) abort();
  if (ra == 0 && rb == 0 && ia.total != ib.total && rand_ != -EINVAL) abort();

  /* N-way on the raw bytes after byte 0, cut into 1 + data[0] % 8 pieces of equal size. */
  {
    size_t n = 1 + data[0] % MAX_STREAMS, rest = size - 1, piece = rest / n;
    const uint8_t* s[MAX_STREAMS];
    size_t lens[MAX_STREAMS];
    int all_valid = 1;
    for (size_t i = 0; i < n; i++) {
      s[i] = data + 1 + i * piece;
      lens[i] = i + 1 == n ? rest - i * piece : piece;
      vc_rle_info info;
      if (vc_rle_inspect(s[i], lens[i], &info) != 0) all_valid = 0;
    }
    cross_check(s, lens, n, 2 * rest + 16, all_valid);
    cross_check(s, lens, n, rest / 2, all_valid); /* often too small: ENOSPC must agree too */
  }

  if (ra == 0 && ia.total <= MAX_BITS) {
    size_t nbits = (size_t)ia.total, nbytes = (nbits + 7) / 8;
    uint8_t* bits = malloc(nbytes + 1);
    uint8_t* other = malloc(nbytes + 1);
    if (!bits || !other) abort();
    if (vc_rle_decode(a, alen, bits, nbits) != 0) abort();
    if (count_bits(bits, nbits) != ia.occupied) abort();
    if (vc_rle_decode(a, alen, other, nbits + 1) != -EINVAL) abort();
    if (nbits > 0 && vc_rle_decode(a, alen, other, nbits - 1) != -EINVAL) abort();
    size_t len = 0;
    uint8_t* again = encode_alloc(bits, nbits, &len);
    if (len != alen || (len && memcmp(again, a, len) != 0)) abort();
    free(again);

    /* A second bitset of the same size: A's bits XOR B's bytes (repeated). */
    for (size_t i = 0; i < nbytes; i++) other[i] = bits[i] ^ (blen ? b[i % blen] : 0x5A);
    if (nbits % 8) other[nbytes - 1] &= (uint8_t)((1u << (nbits % 8)) - 1);
    size_t olen = 0, alen2 = 0;
    uint8_t* orle = encode_alloc(other, nbits, &olen);
    for (size_t i = 0; i < nbytes; i++) other[i] &= bits[i];
    uint8_t* expect = encode_alloc(other, nbits, &alen2);
    size_t cap = vc_rle_max_encoded_size(nbits) + 1, got_len = 0;
    uint8_t* got = malloc(cap);
    if (!got) abort();
    if (vc_rle_and(a, alen, orle, olen, got, cap, &got_len) != 0) abort();
    if (got_len != alen2 || (got_len && memcmp(got, expect, got_len) != 0)) abort();
    free(got);

    /* N-way: A and up to 7 more bitsets of its size, A's bits XOR B rotated by i bytes (AND-ed into
     * `all` as they are made), against the chain, the bitwise AND, and ENOSPC one byte short. */
    {
      size_t n = 1 + (blen ? b[0] : 0) % MAX_STREAMS;
      const uint8_t* s[MAX_STREAMS] = {a};
      size_t lens[MAX_STREAMS] = {alen};
      uint8_t* own[MAX_STREAMS] = {NULL};
      uint8_t* all = malloc(nbytes + 1);
      if (!all) abort();
      memcpy(all, bits, nbytes);
      for (size_t k = 1; k < n; k++) {
        for (size_t i = 0; i < nbytes; i++)
          other[i] = bits[i] ^ (blen ? b[(i + k) % blen] : (uint8_t)(0x5A * k));
        if (nbits % 8) other[nbytes - 1] &= (uint8_t)((1u << (nbits % 8)) - 1);
        for (size_t i = 0; i < nbytes; i++) all[i] &= other[i];
        own[k] = encode_alloc(other, nbits, &lens[k]);
        s[k] = own[k];
      }
      size_t want_len = 0, got_n = 0;
      uint8_t* want = encode_alloc(all, nbits, &want_len);
      uint8_t* out_n = malloc(want_len + 1);
      if (!out_n) abort();
      if (vc_rle_and_n(s, lens, n, out_n, want_len, &got_n) != 0) abort();
      if (got_n != want_len || (got_n && memcmp(out_n, want, got_n) != 0)) abort();
      if (want_len && vc_rle_and_n(s, lens, n, out_n, want_len - 1, &got_n) != -ENOSPC) abort();
      if (got_n != want_len) abort();
      cross_check(s, lens, n, want_len, 1);
      free(out_n);
      free(want);
      free(all);
      for (size_t k = 1; k < n; k++) free(own[k]);
    }
    free(expect);
    free(orle);
    free(bits);
    free(other);
  } else if (ra != 0) {
    uint8_t scratch[64];
    for (size_t nbits = 0; nbits < 8 * sizeof scratch; nbits += 61)
      if (vc_rle_decode(a, alen, scratch, nbits) == 0) abort();
  }
  free(out);
  return 0;
}
