#pragma once
// Counts what controllers do into the metrics registry: command latency histogram, commands,
// errors, timeouts, reconnects, connection state, report frames decoded and bytes skipped, and the
// codes of the controllers' own error logs.
// A controller_observer added to the registry; called on each controller's strand (metrics is
// thread-safe, the small per-controller state below is guarded by a mutex).

#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "devices/serial/controller_observer.hpp"
#include "gateway/common/metrics.hpp"

namespace gw::api {

class controller_metrics final : public devices::controller_observer {
  public:
    explicit controller_metrics(std::shared_ptr<gw::metrics> m);

    // Declares every family this class and the HTTP layer use (idempotent).
    static void describe(gw::metrics& m);

    void on_snapshot(const devices::controller_snapshot& snapshot) override;
    void on_report(const devices::report_event& event) override;
    void on_trace(const devices::command_trace& trace) override;
    void on_link_fault(const devices::link_fault& fault) override;
    void on_error_log(const devices::error_log_event& event) override;

  private:
    struct per_controller {
        bool was_connected = false;
        bool ever_connected = false;
        // Found at the first frame: a report stream updates them hundreds of times a second.
        metrics::handle report_frames, report_bytes_skipped;
        // Found at the first successful command: every command updates them.
        metrics::handle user_commands, internal_commands, command_duration;
    };

    std::shared_ptr<gw::metrics> metrics_;
    std::mutex mutex_;
    std::map<std::string, per_controller> state_;
};

}  // namespace gw::api
