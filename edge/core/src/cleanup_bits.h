/* Internal: the clean-up that also hands over the clean mask's foreground as bits, for the
 * limb-scale cue (bgmodel.c: vc_cleanup_grow), in the clean-up's own pass over each row. */
#ifndef VOXCAP_EDGE_CLEANUP_BITS_H
#define VOXCAP_EDGE_CLEANUP_BITS_H

#include <stddef.h>
#include <stdint.h>

/* vc_cleanup_radius(), and for every row y, once the row is final, its foreground pixels (255) as
 * bits at bits + y * bits_stride (bit i of word i / 64, (width + 63) / 64 words, the bits past the
 * width 0) and row_any[y] = whether the row has any. bits == NULL: vc_cleanup_radius() alone.
 * orig != NULL (width x height bytes): the mask as it came in is left there (non-zero = foreground),
 * for the cue to give back what the filter took from the body (bgmodel.c: grow_mask); the filter
 * keeps its originals' rows there instead of in scratch, so this costs no copy more. */
int vc__cleanup_radius_bits(uint8_t* mask, int width, int height, int radius, uint8_t* scratch,
                            size_t scratch_len, uint64_t* bits, size_t bits_stride, uint8_t* row_any,
                            uint8_t* orig);

#endif /* VOXCAP_EDGE_CLEANUP_BITS_H */
