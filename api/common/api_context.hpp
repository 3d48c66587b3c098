#pragma once
// What every HTTP and WebSocket session shares: the registry, the event hub, the metrics, the HTTP
// limits and the auth tokens. Created once by main before the listener starts, held by shared_ptr
// by every session; immutable after creation (the objects it points to are thread-safe).

#include <memory>
#include <string>

#include <boost/asio/any_io_executor.hpp>

#include "api/common/browser_rules.hpp"
#include "gateway/config/config.hpp"

namespace spdlog {
class logger;
}

namespace gw {
class controller_registry;
class controller_state_texts;
class event_hub;
class gcode_file_store;
class lease_manager;
class metrics;
class shared_ports;
}  // namespace gw

namespace gw::jobs {
class job_manager;
}

namespace gw::audit {
class audit_log;
}

namespace gw::recordings {
class recorder;
}

namespace gw::api {

class batch_text_cache;
class mqtt_link_state;
class tls_server_context;
class gcode_worker;
class port_scan_worker;

struct api_context {
    boost::asio::any_io_executor executor;  // the io_context's; sessions make their own strands
    controller_registry& registry;          // outlives every session (main keeps it)
    std::shared_ptr<event_hub> hub;
    std::shared_ptr<gw::metrics> metrics;
    http_limits limits;
    auth_config auth;  // no tokens: every client is admin, and the listener is loopback-only
    std::shared_ptr<spdlog::logger> log;              // "api"
    std::shared_ptr<jobs::job_manager> jobs;          // null: the job routes answer 503
    std::shared_ptr<lease_manager> leases;            // null: no leases (every check passes)
    std::shared_ptr<gcode_file_store> gcode_files{};  // null: the /api/v1/gcode/files routes answer 503
    std::shared_ptr<gcode_worker> gcode_thread{};     // plans and uploads run here; null: inline
    std::shared_ptr<port_scan_worker>
        port_scans{};  // GET /api/v1/ports runs here; null: the route answers 503
    // Each controller's state JSON text, built once per snapshot; null: built per request.
    std::shared_ptr<const controller_state_texts> state_texts{};
    // Batch messages shared by the WebSocket sessions that get the same events; null: one per session.
    std::shared_ptr<batch_text_cache> batch_texts{};
    // What a browser page of another site may not do (api/browser_guard.hpp).
    browser_rules browser{};
    // The controllers' shared ports, shown with each controller; null: none.
    const shared_ports* shares = nullptr;
    // The audit trail of state-changing calls (gateway/audit); null: none kept (no storage directory).
    std::shared_ptr<audit::audit_log> audit{};
    // Reverse proxies whose X-Forwarded-For names the client (http.trusted_proxies).
    trusted_proxies proxies{};
    // HTTPS and WSS (http.tls); null: plain HTTP.
    std::shared_ptr<tls_server_context> tls{};
    // Position recordings (gateway/recordings); null: the recording routes answer 503.
    std::shared_ptr<recordings::recorder> recordings{};
    // The MQTT bridge's link to its broker, for /api/v1/health; null: MQTT is off.
    std::shared_ptr<mqtt_link_state> mqtt_link{};
};

}  // namespace gw::api
