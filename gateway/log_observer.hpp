#pragma once
// Writes what controllers report to the log: connection changes and errors at info/warn, positions
// and report frames at debug, every serial command at trace. It is the only observer until the event
// hub (issue 3) exists. Called on each controller's strand; spdlog loggers are thread-safe.

#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "devices/serial/controller_observer.hpp"

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
    std::shared_ptr<spdlog::logger> log_;
    std::mutex mutex_;  // guards last_ (several controller strands call in)
    std::unordered_map<std::string, devices::controller_snapshot> last_;
};

}  // namespace gw
