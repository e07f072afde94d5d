// Levelled logging for the bridge: the level comes from RAILCOSIM_LOG, the sink is replaceable.
#include "railcosim/Log.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <iostream>
#include <mutex>

namespace railcosim {
namespace {

const char* levelName(LogLevel level) {
  switch (level) {
    case LogLevel::Error:
      return "ERROR";
    case LogLevel::Warning:
      return "WARNING";
    case LogLevel::Info:
      return "INFO";
    case LogLevel::Debug:
      return "DEBUG";
  }
  return "?";
}

LogLevel levelFromEnvironment() {
  const char* text = std::getenv("RAILCOSIM_LOG");
  if (text == nullptr) return LogLevel::Warning;
  std::string value(text);
  std::transform(value.begin(), value.end(), value.begin(), [](unsigned char c) { return std::tolower(c); });
  if (value == "error") return LogLevel::Error;
  if (value == "warning" || value == "warn") return LogLevel::Warning;
  if (value == "info") return LogLevel::Info;
  if (value == "debug") return LogLevel::Debug;
  // An unknown value must not silence errors; it is reported once through the default sink.
  std::cerr << "[railcosim WARNING] RAILCOSIM_LOG='" << value
            << "' is not one of error|warning|info|debug; using warning\n";
  return LogLevel::Warning;
}

struct LogState {
  std::mutex mutex;
  LogLevel level = levelFromEnvironment();
  std::function<void(LogLevel, const std::string&)> sink;
};

LogState& state() {
  static LogState instance;
  return instance;
}

} // namespace

void setLogLevel(LogLevel level) {
  std::lock_guard<std::mutex> lock(state().mutex);
  state().level = level;
}

LogLevel logLevel() {
  std::lock_guard<std::mutex> lock(state().mutex);
  return state().level;
}

void setLogSink(std::function<void(LogLevel, const std::string&)> sink) {
  std::lock_guard<std::mutex> lock(state().mutex);
  state().sink = std::move(sink);
}

void log(LogLevel level, const std::string& message) {
  std::lock_guard<std::mutex> lock(state().mutex);
  if (static_cast<int>(level) > static_cast<int>(state().level)) return;
  if (state().sink) {
    state().sink(level, message);
  } else {
    std::cerr << "[railcosim " << levelName(level) << "] " << message << '\n';
  }
}

} // namespace railcosim
