#pragma once
// An observer that records everything a controller publishes and lets a test wait for a condition.
// Callbacks arrive on the controller's strand; tests read under the mutex. Header-only.

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <vector>

#include "devices/serial/controller_observer.hpp"

namespace gw::test {

class drv_recording_observer : public devices::controller_observer {
  public:
    void on_snapshot(const devices::controller_snapshot& s) override {
        record([&] { snapshots.push_back(s); });
    }
    void on_report(const devices::report_event& e) override {
        record([&] { reports.push_back(e); });
    }
    void on_ttl(const devices::ttl_event& e) override {
        record([&] { ttls.push_back(e); });
    }
    void on_error_log(const devices::error_log_event& e) override {
        record([&] { error_logs.push_back(e); });
    }
    void on_trace(const devices::command_trace& t) override {
        record([&] {
            traces.push_back(t);
            trace_times.push_back(std::chrono::steady_clock::now());
        });
    }
    void on_link_fault(const devices::link_fault& f) override {
        record([&] { faults.push_back(f.what); });
    }

    // Waits until `pred` (called under the lock) holds; false on timeout.
    bool wait(const std::function<bool()>& pred,
              std::chrono::milliseconds timeout = std::chrono::seconds(15)) {
        std::unique_lock lock(mu_);
        return cv_.wait_for(lock, timeout, pred);
    }

    bool wait_state(devices::connection_state state,
                    std::chrono::milliseconds timeout = std::chrono::seconds(15)) {
        return wait([&] { return !snapshots.empty() && snapshots.back().state == state; }, timeout);
    }

    devices::controller_snapshot latest() {
        std::lock_guard lock(mu_);
        return snapshots.empty() ? devices::controller_snapshot{} : snapshots.back();
    }

    template <typename F>
    auto locked(F&& f) {
        std::lock_guard lock(mu_);
        return f();
    }

    // Guarded by the mutex: read through wait()/locked().
    std::vector<devices::controller_snapshot> snapshots;
    std::vector<devices::report_event> reports;
    std::vector<devices::ttl_event> ttls;
    std::vector<devices::error_log_event> error_logs;
    std::vector<devices::command_trace> traces;
    std::vector<std::chrono::steady_clock::time_point> trace_times;  // when each trace arrived
    std::vector<devices::link_fault::kind> faults;

  private:
    template <typename F>
    void record(F&& f) {
        {
            std::lock_guard lock(mu_);
            f();
        }
        cv_.notify_all();
    }

    std::mutex mu_;
    std::condition_variable cv_;
};

}  // namespace gw::test
