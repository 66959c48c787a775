/* Internal: which variant of the hot kernels runs. Every kernel is written once in portable C
 * (VC_HOT inline bodies) and compiled twice on x86-64: for the baseline ISA and, in functions marked
 * VC_TARGET_AVX2, for AVX2, so that the compiler's auto-vectoriser can use 32-byte vectors. On
 * aarch64 the kernels whose portable form the compiler cannot map onto NEON well (the interleaved
 * pixel classification, the carver's bit packing) have hand-written NEON variants (Advanced SIMD is in
 * every ARMv8-A core, so nothing is probed); the 3x3 majority filter's rows are byte arithmetic that
 * gcc vectorises for NEON itself, and the RLE's NEON word skip is proto's (vc_rle_encode_impl()). The choice
 * is made once, lazily (cpuid on x86-64); vc_edge_kernel_select() overrides it for tests and benchmarks, and
 * "generic" is the portable C on every CPU: the reference the other variants must equal bit for bit. */
#ifndef VOXCAP_EDGE_DISPATCH_H
#define VOXCAP_EDGE_DISPATCH_H

#include <stdbool.h>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define VC_HAVE_AVX2_VARIANT 1
#define VC_TARGET_AVX2 __attribute__((target("avx2")))
#else
#define VC_HAVE_AVX2_VARIANT 0
#define VC_TARGET_AVX2
#endif

#if defined(__aarch64__) && defined(__ARM_NEON)
#define VC_HAVE_NEON_VARIANT 1
#else
#define VC_HAVE_NEON_VARIANT 0
#endif

#if defined(__GNUC__) || defined(__clang__)
#define VC_HOT static inline __attribute__((always_inline))
#else
#define VC_HOT static inline
#endif

/* True when the AVX2 variants are selected (lazily initialised to the best available). */
bool vc__use_avx2(void);
/* True when the NEON variants are selected (the default on aarch64). */
bool vc__use_neon(void);

#endif /* VOXCAP_EDGE_DISPATCH_H */
