/* vc_log: the edge daemon's one logger (see log.h). */
#define _GNU_SOURCE /* localtime_r */
#include "log.h"

#include <stdatomic.h>
#include <stdio.h>
#include <time.h>

#include "voxcap/edge/clock.h"
#include "voxcap/why.h"

static atomic_int g_min = VC_LOG_INFO;
static vc_log_sink g_sink;
static void* g_sink_user;

const char* vc_log_level_name(vc_log_level level) {
  switch (level) {
    case VC_LOG_DEBUG:
      return "debug";
    case VC_LOG_INFO:
      return "info";
    case VC_LOG_WARN:
      return "warning";
    case VC_LOG_ERROR:
      return "error";
  }
  return NULL;
}

void vc_log_set_level(vc_log_level min) {
  atomic_store(&g_min, (int)min);
}
vc_log_level vc_log_get_level(void) {
  return (vc_log_level)atomic_load(&g_min);
}

vc_log_level vc_log_level_from_verbosity(int verbosity) {
  if (verbosity <= 0) return VC_LOG_WARN;
  return verbosity == 1 ? VC_LOG_INFO : VC_LOG_DEBUG;
}

int vc_log_enabled(vc_log_level level) {
  return (int)level >= atomic_load(&g_min) && vc_log_level_name(level);
}

void vc_log_set_sink(vc_log_sink sink, void* user) {
  g_sink_user = user;
  g_sink = sink;
}

void vc_logv(vc_log_level level, const char* fmt, va_list ap) {
  if (!vc_log_enabled(level)) return;
  char msg[640];
  vc_whyv(msg, sizeof msg, fmt, ap);
  if (g_sink) {
    g_sink(g_sink_user, level, msg);
    return;
  }
  /* spdlog's default pattern: [%Y-%m-%d %H:%M:%S.%e] [%l] (local time) */
  uint64_t now_ns = vc_clock_now_ns(VC_CLOCK_REALTIME);
  time_t secs = (time_t)(now_ns / 1000000000u);
  struct tm tm;
  char stamp[32] = "";
  if (localtime_r(&secs, &tm)) strftime(stamp, sizeof stamp, "%Y-%m-%d %H:%M:%S", &tm);
  char line[720];
  vc_why(line, sizeof line, "[%s.%03u] [%s] voxcap-edge: %s\n", stamp, (unsigned)(now_ns / 1000000u % 1000u),
         vc_log_level_name(level), msg);
  fputs(line, stderr);
}

void vc_log(vc_log_level level, const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vc_logv(level, fmt, ap);
  va_end(ap);
}
