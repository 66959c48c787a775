/* CRC32C (Castagnoli, reflected polynomial 0x82F63B78), the checksum of the voxcap framing.
 *
 * Parameters as in RFC 3720 / iSCSI: init 0xFFFFFFFF, reflected in and out, final xor 0xFFFFFFFF.
 * Check value: CRC32C("123456789") == 0xE3069283; CRC32C of zero bytes == 0.
 * Thread-safe; no allocation. x86-64 CPUs with SSE4.2 use the crc32 instruction, everything else
 * a portable slicing-by-8 table implementation; both give identical results.
 */
#ifndef VOXCAP_CRC32C_H
#define VOXCAP_CRC32C_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Extends `crc` (the CRC32C of the bytes before `data`, 0 for none) over `len` bytes of `data`.
 * vc_crc32c(0, d, n) is the CRC32C of d[0..n); vc_crc32c(vc_crc32c(0, a, n), b, m) is the CRC32C of
 * the concatenation. `data` may be NULL when `len` is 0. */
uint32_t vc_crc32c(uint32_t crc, const void* data, size_t len);

/* The portable table implementation, whatever the CPU. Same contract as vc_crc32c; exposed so tests
 * and benchmarks can compare it with the accelerated path. */
uint32_t vc_crc32c_portable(uint32_t crc, const void* data, size_t len);

/* Name of the implementation vc_crc32c uses on this CPU ("sse4.2" or "slicing-by-8"). Static string. */
const char* vc_crc32c_impl(void);

#ifdef __cplusplus
}
#endif

#endif /* VOXCAP_CRC32C_H */
