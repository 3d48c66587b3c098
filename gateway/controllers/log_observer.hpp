#pragma once
// Writes what controllers report to the log: connection changes and errors at info/warn (repeated
// errors rate-limited; an unreachable controller's reason and hint when it changes, else once a
// minute, with the number of failed attempts since), positions and report frames at debug on "gateway"; every
// serial command on "ms2000.<id>" with its request id: user commands at debug, the driver's polls at trace.
// Joins the registry's observers. Called on each controller's strand; spdlog loggers are thread-safe.

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "devices/serial/controller_observer.hpp"
#include "gateway/config/logging.hpp"

namespace spdlog {
class logger;
}

namespace gw {

class log_observer final : public devices::controller_observer {
  public:
    log_observer();

    void on_snapshot(const devices::controller_snapshot& snapshot) override;
    void on_report(const devices::report_event& event) override;
    void on_ttl(const devices::ttl_event& event) override;
    void on_trace(const devices::command_trace& trace) override;

  private:
    void log_unreachable(const devices::controller_snapshot& s);

    std::shared_ptr<spdlog::logger> log_;
    std::mutex mutex_;  // guards last_ (several controller strands call in)
    std::unordered_map<std::string, devices::controller_snapshot> last_;
    keyed_log_limiter limiter_;

    // Per unreachable controller: the reason last logged, when, and the attempts not logged since.
    struct unreachable_log {
        std::string name;
        std::chrono::steady_clock::time_point at{};
        std::uint64_t unlogged = 0;
    };
    std::unordered_map<std::string, unreachable_log> unreachable_;  // guarded by mutex_
};

}  // namespace gw
