/* Kernel variant selection (see dispatch.h). */
#include "dispatch.h"

#include <errno.h>
#include <string.h>

#include "voxcap/edge/bgmodel.h"

/* -1 = not decided yet, 0 = generic, 1 = avx2. A plain int: selection is documented as not
 * thread-safe, and the lazy default is idempotent. */
static int g_variant = -1;

static bool cpu_has_avx2(void) {
#if VC_HAVE_AVX2_VARIANT
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") != 0;
#else
  return false;
#endif
}

bool vc__use_avx2(void) {
  if (g_variant < 0) g_variant = cpu_has_avx2() ? 1 : 0;
  return g_variant == 1;
}

const char *vc_edge_kernel_name(void) { return vc__use_avx2() ? "avx2" : "generic"; }

int vc_edge_kernel_select(const char *name) {
  if (name == NULL) return -EINVAL;
  if (strcmp(name, "auto") == 0) {
    g_variant = cpu_has_avx2() ? 1 : 0;
    return 0;
  }
  if (strcmp(name, "generic") == 0) {
    g_variant = 0;
    return 0;
  }
  if (strcmp(name, "avx2") == 0) {
    if (!cpu_has_avx2()) return -ENOTSUP;
    g_variant = 1;
    return 0;
  }
  return -EINVAL;
}
