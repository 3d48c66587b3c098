#pragma once
// What a controller tells the outside world. Knows nothing of JSON, HTTP or MQTT.
// Every callback runs on the controller's strand: keep it short, never block, never throw, copy what
// you need and post it elsewhere. The controller holds the observer by weak_ptr, so the owner decides its
// lifetime.

#include "devices/serial/controller_events.hpp"
#include "devices/serial/controller_snapshot.hpp"

namespace gw::devices {

class controller_observer {
  public:
    virtual ~controller_observer() = default;

    virtual void on_snapshot(const controller_snapshot& snapshot) {}  // only when something changed
    virtual void on_report(const report_event& event) {}
    virtual void on_ttl(const ttl_event& event) {}
    virtual void on_error_log(const error_log_event& event) {}
    virtual void on_trace(const command_trace& trace) {}
    virtual void on_link_fault(const link_fault& fault) {}
};

}  // namespace gw::devices
