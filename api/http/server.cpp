#include "api/http/server.hpp"

#include <filesystem>
#include <stdexcept>

#include <spdlog/logger.h>

#include "api/calls/share_json.hpp"
#include "api/common/controller_metrics.hpp"
#include "api/common/gcode_worker.hpp"
#include "api/common/port_scan_worker.hpp"
#include "api/http/listener.hpp"
#include "api/ws/batch_text_cache.hpp"
#include "gateway/audit/audit_log.hpp"
#include "gateway/common/metrics.hpp"
#include "gateway/config/logging.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/storage/gcode_files.hpp"

namespace gw::api {

namespace {

// Uploaded G-code programs live next to the job database: <storage.path>/gcode/.
std::shared_ptr<gcode_file_store> make_gcode_store(const gateway_config& config) {
    return std::make_shared<gcode_file_store>(gcode_file_store_settings{
        gcode_directory(config.storage.path), config.gcode.max_file_mb * 1024 * 1024});
}

// The audit trail next to the job database: <storage.path>/audit.sqlite3. Without a storage directory
// (some tests) there is none, and GET /api/v1/audit answers 503.
std::shared_ptr<audit::audit_log> make_audit_log(const gateway_config& config) {
    if (config.storage.path.empty()) return nullptr;
    auto log = audit::audit_log::open(config.storage.path, get_logger("api"), config.storage.retention);
    if (!log) {
        get_logger("api")->error("no audit trail: {}", log.error());
        return nullptr;
    }
    return std::move(*log);
}

}  // namespace

server::server(const io_executor& executor, const gateway_config& config, controller_registry& registry,
               std::shared_ptr<event_hub> hub, std::shared_ptr<gw::metrics> metrics,
               std::shared_ptr<jobs::job_manager> jobs, std::shared_ptr<lease_manager> leases,
               std::shared_ptr<const controller_state_texts> state_texts, const shared_ports* shares,
               std::shared_ptr<tls_server_context> tls, std::shared_ptr<recordings::recorder> recordings)
    : executor_(executor),
      http_(config.http),
      ctx_(std::make_shared<api_context>(api_context{
          executor,
          registry,
          std::move(hub),
          std::move(metrics),
          config.http.limits,
          config.auth,
          get_logger("api"),
          std::move(jobs),
          std::move(leases),
          make_gcode_store(config),
          std::make_shared<api::gcode_worker>(),
          std::make_shared<api::port_scan_worker>(),
          std::move(state_texts),
          std::make_shared<batch_text_cache>(),
          browser_rules{config.http.allowed_origins, config.http.allowed_hosts, config.auth.tokens.empty()},
          shares,
          make_audit_log(config),
          config.http.proxies,
          std::move(tls),
          std::move(recordings)})) {
    // main holds the storage lock by now: no other gateway uploads into this store.
    if (auto stale = ctx_->gcode_files->remove_stale_temporaries())
        ctx_->log->info("removed {} unfinished G-code uploads from {}", stale,
                        ctx_->gcode_files->settings().directory.string());
    controller_metrics::describe(*ctx_->metrics);
    ctx_->metrics->describe(
        "gw_job_store_fill_ratio", metric_type::gauge,
        "How full the job store is against storage.max_size_mb (0..1); the log warns at 0.8");
    describe_share_metrics(*ctx_);
    // Gauges exist from the start (a scrape before the first client sees 0, not nothing).
    ctx_->metrics->set("gw_http_connections", {}, 0);
    ctx_->metrics->set("gw_websocket_clients", {}, 0);
    registry.add_observer(
        std::shared_ptr<devices::controller_observer>(std::make_shared<controller_metrics>(ctx_->metrics)));
}

server::~server() {
    stop();
}

void server::start() {
    if (ctx_->auth.tokens.empty() && !is_loopback_address(http_.listen_address))
        throw std::runtime_error("refusing to listen on " + http_.listen_address +
                                 " without auth tokens: configure auth.tokens or listen on 127.0.0.1");
    beast::error_code ec;
    auto address = net::ip::make_address(http_.listen_address, ec);
    if (ec) throw std::runtime_error("http.listen_address \"" + http_.listen_address + "\": " + ec.message());
    try {
        listener_ = std::make_shared<listener>(executor_, net::ip::tcp::endpoint(address, http_.port), ctx_);
    } catch (const boost::system::system_error& e) {
        throw std::runtime_error("cannot listen on " + http_.listen_address + ":" +
                                 std::to_string(http_.port) + ": " + e.code().message());
    }
    listener_->run();
    auto ep = listener_->local_endpoint();
    const char* scheme = ctx_->tls ? "https" : "http";
    if (ctx_->auth.tokens.empty())
        ctx_->log->info("listening on {}://{}:{} (no auth tokens: loopback only, every client is admin)",
                        scheme, ep.address().to_string(), ep.port());
    else
        ctx_->log->info("listening on {}://{}:{} ({} auth tokens)", scheme, ep.address().to_string(),
                        ep.port(), ctx_->auth.tokens.size());
}

void server::stop() {
    if (listener_) listener_->stop();
    if (ctx_->gcode_thread) ctx_->gcode_thread->stop();  // the running plan finishes and answers
    if (ctx_->port_scans) ctx_->port_scans->stop();      // so does a running port scan
}

net::ip::tcp::endpoint server::local_endpoint() const {
    return listener_ ? listener_->local_endpoint() : net::ip::tcp::endpoint{};
}

}  // namespace gw::api
