/* Internal: which variant of the hot kernels runs. Every kernel is written once in portable C
 * (VC_HOT inline bodies) and compiled twice on x86-64: for the baseline ISA and, in functions marked
 * VC_TARGET_AVX2, for AVX2, so that the compiler's auto-vectoriser can use 32-byte vectors. The
 * choice is made once at run time (cpuid); other CPUs (aarch64 with NEON) use the baseline build,
 * which the compiler vectorises for that ISA. */
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

#if defined(__GNUC__) || defined(__clang__)
#define VC_HOT static inline __attribute__((always_inline))
#else
#define VC_HOT static inline
#endif

/* True when the AVX2 variants are selected (lazily initialised to the best available). */
bool vc__use_avx2(void);

#endif /* VOXCAP_EDGE_DISPATCH_H */
