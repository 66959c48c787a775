/* Kernel variant selection (see dispatch.h). */
#include "dispatch.h"

#include <errno.h>
#include <string.h>

#include "voxcap/edge/bgmodel.h"

enum { VARIANT_UNSET = -1, VARIANT_GENERIC = 0, VARIANT_AVX2 = 1, VARIANT_NEON = 2 };

/* A plain int: selection is documented as not thread-safe, and the lazy default is idempotent. */
static int g_variant = VARIANT_UNSET;

static bool cpu_has_avx2(void) {
#if VC_HAVE_AVX2_VARIANT
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") != 0;
#else
  return false;
#endif
}

/* Advanced SIMD is mandatory in ARMv8-A: an aarch64 build always runs it. */
static bool cpu_has_neon(void) {
  return VC_HAVE_NEON_VARIANT != 0;
}

static int best_variant(void) {
  if (cpu_has_avx2()) return VARIANT_AVX2;
  if (cpu_has_neon()) return VARIANT_NEON;
  return VARIANT_GENERIC;
}

bool vc__use_avx2(void) {
  if (g_variant == VARIANT_UNSET) g_variant = best_variant();
  return g_variant == VARIANT_AVX2;
}

bool vc__use_neon(void) {
  if (g_variant == VARIANT_UNSET) g_variant = best_variant();
  return g_variant == VARIANT_NEON;
}

const char* vc_edge_kernel_name(void) {
  if (vc__use_avx2()) return "avx2";
  return vc__use_neon() ? "neon" : "generic";
}

int vc_edge_kernel_select(const char* name) {
  if (name == NULL) return -EINVAL;
  if (strcmp(name, "auto") == 0) {
    g_variant = best_variant();
    return 0;
  }
  if (strcmp(name, "generic") == 0) {
    g_variant = VARIANT_GENERIC;
    return 0;
  }
  if (strcmp(name, "avx2") == 0) {
    if (!cpu_has_avx2()) return -ENOTSUP;
    g_variant = VARIANT_AVX2;
    return 0;
  }
  if (strcmp(name, "neon") == 0) {
    if (!cpu_has_neon()) return -ENOTSUP;
    g_variant = VARIANT_NEON;
    return 0;
  }
  return -EINVAL;
}
