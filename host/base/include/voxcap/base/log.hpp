// The host's one logger: spdlog, with spdlog's level scale (trace < debug < info < warn < err <
// critical; the edge's vc_log uses the same names) and one line on stderr that reads like the edge's:
//
//   [2026-11-24 13:21:04.123] [warning] voxcap-host: node 2 (front-left) left: heartbeat timeout
//
// A component that lets its owner capture its lines (tests do; the emulated rig keeps only errors
// when quiet) takes a vc::log::Fn; without one it writes to spdlog through to_spdlog(). Code with no
// owner to ask logs with spdlog::info(...) etc., which goes to the program's logger once main called
// init().
#pragma once

#include <spdlog/common.h>

#include <functional>
#include <memory>
#include <string>

namespace spdlog {
class logger;
}

namespace vc::log {

using Level = spdlog::level::level_enum;  // Level::debug, Level::info, Level::warn, Level::err, ...

// Where a component's lines go: a level and the line (no program name, no newline).
using Fn = std::function<void(Level level, const std::string& line)>;

// spdlog's default line with the program's name where the edge daemon prints "voxcap-edge:".
inline constexpr const char* kPattern = "[%Y-%m-%d %H:%M:%S.%e] [%l] %n: %v";

// Makes the logger named `program` spdlog's default (so spdlog::info(...) writes there) and sets the
// threshold of every logger. Call it first in main. Throws spdlog::spdlog_ex (not expected).
void init(const std::string& program, Level threshold = Level::info);

// The logger named `program`: on stderr with kPattern, one shared sink (lines never interleave), made
// on first use at the current threshold. Thread-safe.
std::shared_ptr<spdlog::logger> logger(const std::string& program);

// An Fn that writes to spdlog: to logger(program), or with no program to spdlog's default logger as
// it is when a line is written (the program's, after init()).
Fn to_spdlog(const std::string& program = {});

// `fn` when it is set, else to_spdlog(program): a component's default.
Fn or_spdlog(Fn fn, const std::string& program = {});

}  // namespace vc::log
