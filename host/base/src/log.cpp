#include "voxcap/base/log.hpp"

#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>

#include <mutex>

namespace vc::log {

namespace {

// One stderr sink for every logger of the process: its mutex keeps lines whole.
const std::shared_ptr<spdlog::sinks::stderr_sink_mt>& stderr_sink() {
  static const auto sink = std::make_shared<spdlog::sinks::stderr_sink_mt>();
  return sink;
}

std::mutex g_make_mu;  // get-or-make of a named logger is one step

}  // namespace

std::shared_ptr<spdlog::logger> logger(const std::string& program) {
  std::lock_guard<std::mutex> g(g_make_mu);
  if (auto existing = spdlog::get(program)) return existing;
  auto l = std::make_shared<spdlog::logger>(program, stderr_sink());
  spdlog::initialize_logger(l);  // registered, at the current threshold
  l->set_pattern(kPattern);
  return l;
}

void init(const std::string& program, Level threshold) {
  spdlog::set_default_logger(logger(program));
  spdlog::set_level(threshold);
}

Fn to_spdlog(const std::string& program) {
  if (program.empty())
    return [](Level level, const std::string& line) { spdlog::default_logger_raw()->log(level, line); };
  return [l = logger(program)](Level level, const std::string& line) { l->log(level, line); };
}

Fn or_spdlog(Fn fn, const std::string& program) {
  return fn ? std::move(fn) : to_spdlog(program);
}

}  // namespace vc::log
