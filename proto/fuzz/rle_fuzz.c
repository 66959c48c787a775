/* libFuzzer target: the RLE functions on arbitrary bytes.
 *
 * Input: byte 0 picks a split; the bytes after it are RLE stream A (up to the split) and stream B (the
 * rest). Checked properties, any violation aborts:
 *  - inspect, popcount and decode agree on whether A is valid;
 *  - a valid A of at most 2^18 bits decodes, re-encodes to exactly A (canonical form is unique),
 *    its popcount equals the decoded bit count, and decoding with one bit more or less fails;
 *  - AND of A with a second bitset of the same size (A's bits XOR a pattern from B) equals the RLE of
 *    the bitwise AND; AND of A and B succeeds iff both are valid with equal totals. */
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
