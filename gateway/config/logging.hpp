#pragma once
// spdlog set up from the config: one logger per area ("gateway", "api", "jobs", "mqtt",
// "ms2000.<id>"), all writing to one sink as text or JSON lines, each with its own level.
//
// JSON lines are one object per line:
//   {"time":"2026-11-22T02:45:40.123Z","level":"info","logger":"gateway","message":"ready"}

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>

#include <spdlog/formatter.h>
#include <spdlog/logger.h>

#include "devices/serial/log_limiter.hpp"
#include "gateway/config/config.hpp"

namespace gw {

spdlog::level::level_enum to_spdlog(log_level level);

// Replaces the default logger and every registered logger. `sink` is for tests; by default text goes
// to a coloured stdout sink and JSON to plain stdout. Call at start-up, before controllers exist
// (the driver picks up "ms2000.<id>" when it is created).
void setup_logging(const logging_config& config, std::shared_ptr<spdlog::sinks::sink> sink = {});

// The logger for an area, created with its configured level on the default logger's sinks if new.
std::shared_ptr<spdlog::logger> get_logger(const std::string& name);

// The level `name` gets under `config`: its own entry, else "ms2000" for "ms2000.<id>", else the
// global level.
log_level effective_level(const logging_config& config, std::string_view name);

// One JSON log line (with the trailing newline). `time` is printed in UTC with milliseconds.
std::string format_json_line(std::chrono::system_clock::time_point time, std::string_view level,
                             std::string_view logger, std::string_view message);

class json_formatter final : public spdlog::formatter {
  public:
    void format(const spdlog::details::log_msg& msg, spdlog::memory_buf_t& dest) override;
    std::unique_ptr<spdlog::formatter> clone() const override;
};

// A thread-safe set of devices::log_limiter keyed by message kind ("stage1/timeout"), for errors that
// repeat (a dead controller answering every request with not_connected).
class keyed_log_limiter {
  public:
    explicit keyed_log_limiter(std::chrono::steady_clock::duration interval = std::chrono::seconds(10))
        : interval_(interval) {}

    bool allow(const std::string& key, std::uint64_t& suppressed);

  private:
    std::chrono::steady_clock::duration interval_;
    std::mutex mutex_;
    std::map<std::string, devices::log_limiter, std::less<>> limiters_;
};

}  // namespace gw
