#include "api/common/controller_metrics.hpp"

#include "devices/ms2000/error.hpp"
#include "devices/ms2000/error_log.hpp"

namespace gw::api {

namespace {

std::string error_label(const boost::system::error_code& ec) {
    if (ec.category() != devices::ms2000::error_category()) return "io_error";
    using devices::ms2000::error;
    switch (static_cast<error>(ec.value())) {
        case error::timeout:
            return "timeout";
        case error::unrecognized_reply:
            return "unrecognized_reply";
        case error::line_too_long:
            return "line_too_long";
        case error::controller_rejected:
            return "controller_rejected";
        case error::invalid_argument:
        case error::binary_reply:
            return "invalid_argument";
        case error::queue_full:
            return "queue_full";
        case error::not_connected:
            return "not_connected";
        case error::disconnected:
            return "disconnected";
        case error::cancelled:
            return "cancelled";
        case error::halted:
            return "halted";
    }
    return "other";
}

}  // namespace

controller_metrics::controller_metrics(std::shared_ptr<gw::metrics> m) : metrics_(std::move(m)) {
    describe(*metrics_);
}

void controller_metrics::describe(gw::metrics& m) {
    using enum metric_type;
    m.describe("gw_controller_command_duration_seconds", histogram,
               "Serial command latency (write start to reply), every command incl. polls",
               default_latency_buckets());
    m.describe("gw_controller_commands_total", counter,
               "Serial commands finished, by origin (user, internal)");
    m.describe("gw_controller_command_errors_total", counter, "Serial commands that failed, by error");
    m.describe("gw_controller_command_timeouts_total", counter, "Serial commands without a reply in time");
    m.describe("gw_controller_link_faults_total", counter,
               "Serial line faults by kind: timeout, mismatch (a reply that did not fit its command), "
               "noise, unexpected (bytes nobody asked for), resynced, resync_failed, contained");
    m.describe("gw_controller_reconnects_total", counter,
               "Times a controller connected again after losing it");
    m.describe("gw_controller_connected", gauge, "1 when the controller is connected and identified");
    m.describe("gw_controller_report_frames_total", counter,
               "Encoder report frames decoded (TTL_REPORT port)");
    m.describe("gw_controller_report_bytes_skipped_total", counter,
               "Bytes on the report port that fit no frame");
    m.describe("gw_controller_error_log_total", counter,
               "Codes read from the controller's own error log (DU Y), by code and name "
               "(87 TTL_REPORT_BUFFER_OVERRUN: report frames the controller could not send)");
    m.describe("gw_http_requests_total", counter, "HTTP requests by route, method and status");
    m.describe("gw_http_request_duration_seconds", histogram, "HTTP request handling time by route",
               default_latency_buckets());
    m.describe("gw_http_connections", gauge,
               "Open HTTP connections (WebSocket ones included until upgraded)");
    m.describe("gw_http_connections_refused_total", counter,
               "Connections refused with 503 by reason: limit (every slot serving), address (its share)");
    m.describe("gw_http_tls_handshake_failures_total", counter,
               "TLS handshakes that failed or did not finish within the header timeout (http.tls)");
    m.describe("gw_http_connections_shed_total", counter,
               "Connections closed while waiting for a request header, to make room for a new client");
    m.describe("gw_websocket_clients", gauge, "Connected WebSocket clients");
    m.describe("gw_events_published_total", counter, "Events published to the event hub");
    m.describe("gw_events_delivered_total", counter, "Events handed to subscribers (data and gap)");
    m.describe("gw_events_coalesced_total", counter,
               "Latest-value events replaced by a newer one before delivery (by policy)");
    m.describe("gw_events_gap_events_total", counter, "Gap events sent to subscribers that fell behind");
    m.describe("gw_events_gapped_total", counter, "Stream events reported missing by gap events (dropped)");
    m.describe("gw_events_evicted_subscribers_total", counter, "Subscribers disconnected for being too slow");
    m.describe("gw_event_subscribers", gauge, "Current event hub subscribers (WebSocket, MQTT)");
    m.describe("gw_events_topics", gauge, "Topics the event hub holds a replay buffer for");
    m.describe("gw_events_replay_bytes", gauge,
               "Memory held by the event hub's replay buffers (event text and bookkeeping; "
               "events.replay_memory_mb bounds it)");
    m.describe("gw_events_retired_topics_total", counter,
               "Topics that left the event hub (ended jobs' topics, or the least recent beyond its bound)");
}

void controller_metrics::on_snapshot(const devices::controller_snapshot& s) {
    const bool connected = s.state == devices::connection_state::connected;
    bool reconnected = false;
    {
        std::lock_guard lock(mutex_);
        auto& st = state_[s.id];
        reconnected = connected && !st.was_connected && st.ever_connected;
        st.ever_connected = st.ever_connected || connected;
        st.was_connected = connected;
    }
    metrics_->set("gw_controller_connected", {{"controller", s.id}}, connected ? 1 : 0);
    // Incremented by 0 first so the series exists from the start.
    metrics_->increment("gw_controller_reconnects_total", {{"controller", s.id}}, reconnected ? 1 : 0);
}

void controller_metrics::on_report(const devices::report_event& e) {
    metrics::handle frames, skipped;
    {
        std::lock_guard lock(mutex_);
        auto& st = state_[e.controller_id];
        if (!st.report_frames) {
            st.report_frames =
                metrics_->find("gw_controller_report_frames_total", {{"controller", e.controller_id}});
            st.report_bytes_skipped =
                metrics_->find("gw_controller_report_bytes_skipped_total", {{"controller", e.controller_id}});
        }
        frames = st.report_frames;
        skipped = st.report_bytes_skipped;
    }
    metrics_->increment(frames);
    // bytes_skipped is the decoder's running count: mirror it.
    metrics_->set(skipped, static_cast<double>(e.bytes_skipped));
}

void controller_metrics::on_trace(const devices::command_trace& t) {
    if (t.error) {
        metrics_->increment("gw_controller_commands_total",
                            {{"controller", t.controller_id}, {"origin", t.internal ? "internal" : "user"}});
        metrics_->increment("gw_controller_command_errors_total",
                            {{"controller", t.controller_id}, {"error", error_label(t.error)}});
        if (t.error == devices::ms2000::error::timeout)
            metrics_->increment("gw_controller_command_timeouts_total", {{"controller", t.controller_id}});
        return;
    }
    metrics::handle commands, duration;
    {
        std::lock_guard lock(mutex_);
        auto& st = state_[t.controller_id];
        if (!st.command_duration) {
            const auto& id = t.controller_id;
            st.user_commands =
                metrics_->find("gw_controller_commands_total", {{"controller", id}, {"origin", "user"}});
            st.internal_commands =
                metrics_->find("gw_controller_commands_total", {{"controller", id}, {"origin", "internal"}});
            st.command_duration =
                metrics_->find("gw_controller_command_duration_seconds", {{"controller", id}});
        }
        commands = t.internal ? st.internal_commands : st.user_commands;
        duration = st.command_duration;
    }
    metrics_->increment(commands);
    metrics_->observe(duration, std::chrono::duration<double>(t.latency).count());
}

void controller_metrics::on_error_log(const devices::error_log_event& e) {
    for (const int code : e.codes)
        metrics_->increment("gw_controller_error_log_total",
                            {{"controller", e.controller_id},
                             {"code", std::to_string(code)},
                             {"name", std::string(devices::ms2000::error_log_name(code))}});
}

void controller_metrics::on_link_fault(const devices::link_fault& f) {
    metrics_->increment("gw_controller_link_faults_total",
                        {{"controller", f.controller_id}, {"kind", std::string(devices::to_string(f.what))}});
}

}  // namespace gw::api
