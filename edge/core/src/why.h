/* core_why: how edge/core fills a caller's `char* why, size_t why_len` reason buffer.
 *
 * The same rules as edge/trigger's vc_why() (voxcap/edge/why.h, the edge's convention in
 * edge/README.md): printf-style, always NUL-terminated, silently truncated to why_len - 1 bytes, a
 * no-op when why is NULL or why_len is 0. edge/core links nothing of ours, so it keeps this private
 * static copy instead of linking vc_edge_clock.
 */
#ifndef VOXCAP_EDGE_CORE_WHY_H
#define VOXCAP_EDGE_CORE_WHY_H

#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>

static inline void core_why(char* why, size_t why_len, const char* fmt, ...)
    __attribute__((format(printf, 3, 4)));

static inline void core_why(char* why, size_t why_len, const char* fmt, ...) {
  if (!why || why_len == 0) return;
  va_list ap;
  va_start(ap, fmt);
  if (vsnprintf(why, why_len, fmt, ap) < 0) why[0] = '\0'; /* encoding error: no half line */
  va_end(ap);
}

/* Empties why (no-op without a buffer): "" means "no reason". */
static inline void core_why_clear(char* why, size_t why_len) {
  if (why && why_len) why[0] = '\0';
}

#endif /* VOXCAP_EDGE_CORE_WHY_H */
