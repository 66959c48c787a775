/* vc_why: fills a caller's reason buffer (see why.h). */
#include "voxcap/edge/why.h"

#include <stdio.h>

void vc_whyv(char* why, size_t why_len, const char* fmt, va_list ap) {
  if (!why || why_len == 0) return;
  if (vsnprintf(why, why_len, fmt, ap) < 0) why[0] = '\0'; /* encoding error: no half line */
}

void vc_why(char* why, size_t why_len, const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vc_whyv(why, why_len, fmt, ap);
  va_end(ap);
}

void vc_why_clear(char* why, size_t why_len) {
  if (why && why_len) why[0] = '\0';
}
