/* Run-length encoding of voxel-hull bitsets (proto/SPEC.md, "RLE").
 *
 * Bitset: voxel (i,j,k) of an nx*ny*nz grid is bit i + nx*(j + ny*k); bit b lives in byte b/8 at bit
 * position b%8 (LSB first). Bits past nbits in the last byte are ignored on input and written as 0.
 *
 * RLE: the lengths of alternating runs, starting with an EMPTY run, each an unsigned LEB128 varint.
 * Canonical form (what the encoder writes and what every function here accepts):
 *   - nbits == 0 encodes as zero bytes;
 *   - otherwise the first (empty) run may be 0 — only when the bitset starts with an occupied bit —
 *     and every later run is >= 1; no run follows the last one;
 *   - varints are minimal (no 0x80 padding, at most 10 bytes, value < 2^64).
 * Anything else is rejected with -EBADMSG, so a valid RLE byte string and a bitset correspond 1:1.
 *
 * All functions: no allocation, thread-safe, return 0 or a negative errno code:
 *   -EINVAL  NULL where a buffer is needed, or runs that do not sum to the expected total
 *   -EBADMSG malformed RLE (bad varint, non-canonical zero run, total overflowing 64 bits)
 *   -ENOSPC  the output does not fit into `cap` bytes
 * Buffers are borrowed for the duration of the call only.
 */
#ifndef VOXCAP_RLE_H
#define VOXCAP_RLE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Worst-case encoded size of an nbits-bit bitset (every bit its own run, plus a leading 0 run):
 * nbits + 1 for nbits > 0, 0 for nbits == 0. Saturates at SIZE_MAX. */
size_t vc_rle_max_encoded_size(size_t nbits);

/* Encodes ceil(nbits/8) bytes of `bits` into `out`. On success *out_len = bytes written. On -ENOSPC
 * *out_len = the size the encoding needs (out holds a truncated prefix). Skips all-0 and all-1 64-bit
 * words and finds run ends with count-trailing-zeros, so cost is ~nbits/64 word loads + runs. */
int vc_rle_encode(const uint8_t* bits, size_t nbits, uint8_t* out, size_t cap, size_t* out_len);

/* Decodes `rle` into ceil(nbits/8) bytes of `bits` (whole bytes overwritten, padding bits 0).
 * -EINVAL when the runs do not sum to exactly nbits, -EBADMSG when malformed. `bits` is fully
 * validated against nbits before the first run is written past its end, but its contents are
 * unspecified after an error. */
int vc_rle_decode(const uint8_t* rle, size_t len, uint8_t* bits, size_t nbits);

/* Intersection (bitwise AND) of two RLE streams, computed run by run without a bitset: cost is
 * O(runs(a) + runs(b)). Both inputs must be canonical and have the same total (-EINVAL otherwise);
 * the output is canonical. `out` must not overlap the inputs. On -ENOSPC *out_len is the needed size. */
int vc_rle_and(const uint8_t* a, size_t alen, const uint8_t* b, size_t blen, uint8_t* out, size_t cap,
               size_t* out_len);

/* Most streams vc_rle_and_n takes in one call (its cursors live on the stack). */
#define VC_RLE_AND_MAX_STREAMS 64

/* Intersection of n RLE streams in one pass: streams[i] holds lens[i] bytes (NULL allowed when
 * lens[i] == 0). The output is byte for byte what the chain
 * vc_rle_and(...vc_rle_and(s0, s1)..., s[n-1]) writes; n == 1 validates the stream and copies it,
 * n == 2 is vc_rle_and. `out` must not overlap the inputs.
 * Errors: -EINVAL for n == 0, n > VC_RLE_AND_MAX_STREAMS, NULL arrays or buffers, or streams of
 * different totals; -EBADMSG for a malformed stream (when one stream is malformed and another of a
 * different total, either code, as with vc_rle_and); -ENOSPC with *out_len the needed size (out's
 * contents are then unspecified). As with the chain, only canonical streams of one total succeed.
 * Cost: every input run is read once, plus O(n) per occupied run of the output; the chain reads and
 * writes every intermediate result as well. On partial hulls (a few long runs per grid row) that
 * makes it faster from n = 3 on. On dense inputs with many short empty runs (about one output run
 * per input run) the chain is as fast, and faster for n >= 8 (proto_bench BM_MergeChain, BM_MergeN). */
int vc_rle_and_n(const uint8_t* const* streams, const size_t* lens, size_t n, uint8_t* out, size_t cap,
                 size_t* out_len);

/* Validates `rle` and counts its occupied bits and total bits (either pointer may be NULL). */
int vc_rle_popcount(const uint8_t* rle, size_t len, uint64_t* occupied, uint64_t* total);

/* Everything a receiver checks about an RLE stream, in one pass. */
typedef struct vc_rle_info {
  uint64_t total;    /* sum of all runs: the number of voxels */
  uint64_t occupied; /* sum of the occupied (odd-position) runs */
  uint64_t runs;     /* number of runs, including a leading 0 run */
} vc_rle_info;

/* Validates `rle` and fills `info` (not NULL). Same errors as vc_rle_popcount. */
int vc_rle_inspect(const uint8_t* rle, size_t len, vc_rle_info* info);

/* vc_rle_encode that also reports the stream's vc_rle_info (NULL allowed) at no extra cost: what
 * the HULL encoder uses to fill occupied_count without a second pass. On -ENOSPC info is complete. */
int vc_rle_encode_info(const uint8_t* bits, size_t nbits, uint8_t* out, size_t cap, size_t* out_len,
                       vc_rle_info* info);

/* Which scan over whole empty or occupied words vc_rle_encode and vc_rle_encode_info use: "neon" on
 * aarch64 (Advanced SIMD is in every ARMv8-A core: 64 bytes a step), "portable" elsewhere (64-bit
 * words, four a step). Static string. Either writes the same bytes. */
const char* vc_rle_encode_impl(void);

/* vc_rle_encode_info with the portable scan whatever the CPU: the reference the NEON scan is checked
 * against byte for byte (edge/core's kernels_test), and a baseline for benchmarks. */
int vc_rle_encode_info_portable(const uint8_t* bits, size_t nbits, uint8_t* out, size_t cap, size_t* out_len,
                                vc_rle_info* info);

#ifdef __cplusplus
}
#endif

#endif /* VOXCAP_RLE_H */
