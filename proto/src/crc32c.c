/* CRC32C, two ways: slicing-by-8 tables (Kounavis & Berry, "A Systematic Approach to Building High
 * Performance Software-based CRC Generators", 2005) everywhere, and the SSE4.2 crc32 instruction on
 * x86-64 CPUs that have it, chosen once at first use. The tables are built at first use too (8 KiB),
 * under pthread_once, so the library needs no generated source. Both paths are tested against each
 * other and against the standard check value. Not done: the ARMv8 CRC extension (the Pi 5 has it; the
 * table path runs there at roughly 1 GB/s, which is ample for hull-sized payloads). */
#include "voxcap/crc32c.h"

#include <pthread.h>

#include "wire.h"

#define CRC32C_POLY_REFLECTED 0x82F63B78u

static uint32_t g_table[8][256];
static uint32_t (*g_impl)(uint32_t, const uint8_t*, size_t);
static const char* g_impl_name = "slicing-by-8";
static pthread_once_t g_once = PTHREAD_ONCE_INIT;

/* crc here is the raw (pre-inverted) register. */
static uint32_t crc32c_sw_raw(uint32_t crc, const uint8_t* p, size_t n) {
  while (n >= 8) {
    uint32_t lo = vc_ld32(p) ^ crc;
    uint32_t hi = vc_ld32(p + 4);
    crc = g_table[7][lo & 0xFF] ^ g_table[6][(lo >> 8) & 0xFF] ^ g_table[5][(lo >> 16) & 0xFF] ^
          g_table[4][lo >> 24] ^ g_table[3][hi & 0xFF] ^ g_table[2][(hi >> 8) & 0xFF] ^
          g_table[1][(hi >> 16) & 0xFF] ^ g_table[0][hi >> 24];
    p += 8;
    n -= 8;
  }
  while (n--) crc = g_table[0][(crc ^ *p++) & 0xFF] ^ (crc >> 8);
  return crc;
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <nmmintrin.h>
#define VC_HAVE_SSE42_PATH 1

__attribute__((target("sse4.2"))) static uint32_t crc32c_sse42_raw(uint32_t crc, const uint8_t* p, size_t n) {
  uint64_t c = crc;
  while (n >= 8) {
    uint64_t w;
    memcpy(&w, p, 8);
    c = _mm_crc32_u64(c, w);
    p += 8;
    n -= 8;
  }
  uint32_t c32 = (uint32_t)c;
  while (n--) c32 = _mm_crc32_u8(c32, *p++);
  return c32;
}
#endif

static void crc32c_init(void) {
  for (uint32_t i = 0; i < 256; i++) {
    uint32_t c = i;
    for (int k = 0; k < 8; k++) c = (c >> 1) ^ (CRC32C_POLY_REFLECTED & (0u - (c & 1u)));
    g_table[0][i] = c;
  }
  for (uint32_t i = 0; i < 256; i++) {
    for (int t = 1; t < 8; t++)
      g_table[t][i] = (g_table[t - 1][i] >> 8) ^ g_table[0][g_table[t - 1][i] & 0xFF];
  }
  g_impl = crc32c_sw_raw;
#ifdef VC_HAVE_SSE42_PATH
  __builtin_cpu_init();
  if (__builtin_cpu_supports("sse4.2")) {
    g_impl = crc32c_sse42_raw;
    g_impl_name = "sse4.2";
  }
#endif
}

uint32_t vc_crc32c(uint32_t crc, const void* data, size_t len) {
  pthread_once(&g_once, crc32c_init);
  if (len == 0) return crc;
  return ~g_impl(~crc, (const uint8_t*)data, len);
}

uint32_t vc_crc32c_portable(uint32_t crc, const void* data, size_t len) {
  pthread_once(&g_once, crc32c_init);
  if (len == 0) return crc;
  return ~crc32c_sw_raw(~crc, (const uint8_t*)data, len);
}

const char* vc_crc32c_impl(void) {
  pthread_once(&g_once, crc32c_init);
  return g_impl_name;
}
