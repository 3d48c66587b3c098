#include "devices/serial/event_outlet.hpp"

#include <utility>

#include <spdlog/spdlog.h>

#include "devices/serial/escape.hpp"

namespace gw::devices {
using std::chrono::steady_clock;
using std::chrono::system_clock;

event_outlet::event_outlet(std::string controller_id, controller_snapshot& snapshot, spdlog::logger& log,
                           std::weak_ptr<controller_observer> observer)
    : id_(std::move(controller_id)), snapshot_(snapshot), log_(log), observer_(std::move(observer)) {}

void event_outlet::set_observer(std::weak_ptr<controller_observer> observer) {
    observer_ = std::move(observer);
}

void event_outlet::publish_snapshot() {
    if (published_ && same_content(*published_, snapshot_)) return;
    if (!published_ || published_->state != snapshot_.state)
        log_.info("state {}", to_string(snapshot_.state));
    snapshot_.updated = system_clock::now();
    published_ = snapshot_;
    notify("snapshot", [&](controller_observer& o) { o.on_snapshot(snapshot_); });
}

void event_outlet::report(const report_event& event) {
    notify("report", [&](controller_observer& o) { o.on_report(event); });
}

void event_outlet::ttl(const ttl_event& event) {
    notify("ttl", [&](controller_observer& o) { o.on_ttl(event); });
}

void event_outlet::error_log(const error_log_event& event) {
    notify("error_log", [&](controller_observer& o) { o.on_error_log(event); });
}

template <typename Notify>
void event_outlet::notify(const char* what, Notify&& call) {
    auto obs = observer_.lock();
    if (!obs) return;
    try {
        call(*obs);
    } catch (const std::exception& e) {
        // An observer's fault stays with the event it failed on: the link is not to blame.
        std::uint64_t suppressed = 0;
        if (error_limiter_.allow(steady_clock::now(), suppressed))
            log_.error("observer failed on {} event: {} ({} similar suppressed)", what, e.what(), suppressed);
        fault(link_fault::kind::contained);
    }
}

void event_outlet::trace(const std::string& request_id, bool internal, const std::string& wire,
                         const std::string& raw, boost::system::error_code ec,
                         std::chrono::microseconds latency) {
    auto obs = observer_.lock();
    if (!obs) return;
    command_trace t;
    t.controller_id = id_;
    t.request_id = request_id;
    t.internal = internal;
    t.wire = escape_control(wire);
    t.raw_reply = escape_control(raw);
    t.error = ec;
    t.latency = latency;
    try {
        obs->on_trace(t);
    } catch (const std::exception& e) {
        log_.error("observer failed on trace: {}", e.what());
        fault(link_fault::kind::contained);
    }
}

void event_outlet::fault(link_fault::kind kind) {
    auto obs = observer_.lock();
    if (!obs) return;
    try {
        obs->on_link_fault(link_fault{id_, kind});
    } catch (const std::exception& e) {
        log_.error("observer failed on link fault: {}", e.what());
    }
}

void event_outlet::log_error(const char* what, boost::system::error_code ec) {
    std::uint64_t suppressed = 0;
    if (!error_limiter_.allow(steady_clock::now(), suppressed)) return;
    if (suppressed > 0)
        log_.error("{}: {} ({} similar messages suppressed)", what, ec.message(), suppressed);
    else
        log_.error("{}: {}", what, ec.message());
}

void event_outlet::contained(const char* where, const std::exception& e) {
    // Whatever this controller's input did, it ends here. The other controllers never see it.
    log_.error("{}: {}; resetting the connection", where, e.what());
    fault(link_fault::kind::contained);
}

}  // namespace gw::devices
