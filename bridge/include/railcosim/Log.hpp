// Minimal levelled logging: libraries never print directly; the sink and level are the application's.
#pragma once

#include <functional>
#include <sstream>
#include <string>

namespace railcosim {

enum class LogLevel { Error = 0, Warning = 1, Info = 2, Debug = 3 };

/// Default level: RAILCOSIM_LOG environment variable (error|warning|info|debug), else Warning.
void setLogLevel(LogLevel level);
LogLevel logLevel();
/// Replaces the sink (default: one line to stderr prefixed "[railcosim LEVEL]"). It is also called from the
/// transport's admission thread (refused connections): it must be thread-safe; what it throws there is dropped.
void setLogSink(std::function<void(LogLevel, const std::string&)> sink);
void log(LogLevel level, const std::string& message);

} // namespace railcosim
