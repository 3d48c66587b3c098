#include "api/app/application.hpp"

#include <csignal>
#include <functional>
#include <string>
#include <unistd.h>
#include <utility>
#include <vector>

#include <spdlog/spdlog.h>

#include "api/app/crash_halt.hpp"
#include "api/app/startup_summary.hpp"
#include "api/common/mqtt_link_state.hpp"
#include "api/http/server.hpp"
#include "api/http/tls_server_context.hpp"
#include "api/mqtt/mqtt_bridge.hpp"
#include "gateway/audit/audit_log.hpp"
#include "gateway/common/metrics.hpp"
#include "gateway/common/timestamp.hpp"
#include "gateway/config/logging.hpp"
#include "gateway/controllers/log_observer.hpp"
#include "gateway/events/controller_events_bridge.hpp"
#include "gateway/events/controller_state_texts.hpp"
#include "gateway/events/event_hub.hpp"
#include "gateway/jobs/manager/job_manager.hpp"
#include "gateway/leases/lease_manager.hpp"
#include "gateway/recordings/recorder.hpp"
#include "gateway/share/shared_ports.hpp"
#include "gateway/version.hpp"

namespace gw {

namespace {

using step = std::function<void(std::function<void()> next)>;

// Runs asynchronous steps one after another: each calls `next` when it is done.
void run_in_order(const std::shared_ptr<std::vector<step>>& steps, std::size_t index = 0) {
    if (index == steps->size()) return;
    (*steps)[index]([steps, index] { run_in_order(steps, index + 1); });
}

std::string host_name() {
    char host[256] = {};
    ::gethostname(host, sizeof host - 1);
    return host;
}

}  // namespace

application::application(launch_settings launch) : launch_(std::move(launch)), log_(get_logger("gateway")) {}

application::~application() {
    if (watchdog_.joinable()) watchdog_.join();
    // The job manager has stopped (or never started): what is left there is not run.
    jobs_ioc_.stop();
    if (jobs_thread_.joinable()) jobs_thread_.join();
    // What is still queued on either context is dropped while both still exist (application_io_context).
    jobs_ioc_.shutdown();
    ioc_.shutdown();
}

int application::run() {
    if (!start()) return 1;
    wait_for_signal();
    serve();
    {
        std::lock_guard lock(mutex_);
        finished_ = true;
    }
    finished_cv_.notify_all();
    if (watchdog_.joinable()) watchdog_.join();
    log_->info("stopped");
    return 0;
}

void application::wait_for_signal() {
    signals_.async_wait([this](boost::system::error_code ec, int signal) {
        if (ec) return;
        if (signal == SIGHUP && !from_terminal_) {
            reload_tls();
            return wait_for_signal();
        }
        log_->info("signal {}: stopping", signal);
        shutdown();
    });
}

void application::reload_tls() {
    if (!tls_) {
        log_->info("SIGHUP: nothing to reload (no http.tls)");
        return;
    }
    auto problem = tls_->reload();
    if (!problem.empty())
        log_->error("SIGHUP: TLS certificate not reloaded, the previous one stays: {}", problem);
    else
        log_->info("SIGHUP: TLS certificate reloaded from {}", launch_.config.http.tls.cert_file);
    // A configuration reload is in the audit trail like any change.
    if (auto audit = http_->context()->audit) {
        audit::audit_entry e;
        e.time_ms = epoch_ms(std::chrono::system_clock::now());
        e.principal = "SIGHUP";
        e.role = "admin";
        e.transport = "signal";
        e.action = "tls.reload";
        e.target = launch_.config.http.tls.cert_file;
        e.status = problem.empty() ? 200 : 500;
        e.outcome = problem.empty() ? "ok" : "failed";
        e.detail = problem.empty() ? nlohmann::json::object() : nlohmann::json{{"error", problem}};
        audit->record(std::move(e));
    }
}

bool application::start() {
    // Before any port is opened: a crash from here on halts the stages (crash_halt.hpp).
    install_crash_halt();
    const auto& config = launch_.config;
    from_terminal_ = ::isatty(STDIN_FILENO) == 1;
    // The certificate before anything else: a wrong path ends the start with the file named.
    if (config.http.tls.enabled()) {
        try {
            tls_ = std::make_shared<api::tls_server_context>(config.http.tls);
        } catch (const std::exception& e) {
            log_->error("{}", e.what());
            return false;
        }
    }
    if (config.controllers.empty() && config.simulate.count == 0)
        log_->warn("no controllers configured: give --simulate N, --serial ID=PATH or a config file");
    if (config.auth.tokens.empty())
        log_->info("no auth tokens configured: listening on loopback only ({})", config.http.listen_address);

    // One gateway per storage directory, taken before any serial port is opened.
    auto storage = storage_lock::acquire(config.storage.path);
    if (!storage) {
        log_->error("{}", storage.error().message);
        return false;
    }
    storage_.emplace(std::move(*storage));

    // Observers come before start, so nothing is missed: the log, and the event hub that REST,
    // WebSocket and MQTT read.
    registry_ = std::make_unique<controller_registry>(ioc_.get_executor(), std::move(launch_.registry));
    registry_->add_observer(std::shared_ptr<devices::controller_observer>(std::make_shared<log_observer>()));
    metrics_ = std::make_shared<metrics>();
    event_hub_settings hub_settings;
    hub_settings.max_replay_bytes = config.events.replay_memory_mb * 1024 * 1024;
    hub_ = event_hub::create(ioc_.get_executor(), hub_settings);
    state_texts_ = std::make_shared<controller_state_texts>();
    registry_->add_observer(std::shared_ptr<devices::controller_observer>(
        std::make_shared<controller_events_bridge>(hub_, state_texts_)));

    // Position recordings: <storage>/recordings.sqlite3 (an unusable file is fatal); the
    // job manager's runs record there too.
    recordings::recorder_settings recorder_settings;
    recorder_settings.storage_path = config.storage.path;
    recorder_settings.hub = hub_;
    recorder_settings.max_mb = config.storage.recordings_max_mb;
    auto recorder = recordings::recorder::open(ioc_.get_executor(), *registry_, std::move(recorder_settings));
    if (!recorder) {
        log_->error("cannot open the recordings in \"{}\": {}", config.storage.path,
                    recorder.error().message);
        return false;
    }
    recorder_ = std::move(*recorder);

    // Jobs: leases and the job manager over the durable store (an unusable storage path is fatal).
    leases_ = std::make_shared<lease_manager>();
    auto job_settings = jobs::make_job_manager_settings(config);
    job_settings.recorder = recorder_;
    jobs_work_.emplace(boost::asio::make_work_guard(jobs_ioc_));
    jobs_thread_ = std::thread([this] { run_logging_exceptions(jobs_ioc_); });
    auto jobs = jobs::job_manager::create(ioc_.get_executor(), jobs_ioc_.get_executor(), *registry_, hub_,
                                          leases_, job_settings);
    if (!jobs) {
        log_->error("cannot open the job store in \"{}\": {}", job_settings.storage_path,
                    jobs.error().message);
        return false;
    }
    jobs_ = std::move(*jobs);
    shares_ = std::make_unique<shared_ports>(ioc_.get_executor(), config, *registry_, leases_, jobs_);
    http_ = std::make_unique<api::server>(ioc_.get_executor(), config, *registry_, hub_, metrics_, jobs_,
                                          leases_, state_texts_, shares_.get(), tls_, recorder_);
    shares_->set_audit(http_->context()->audit);
    // Set before any session runs: /api/v1/health reads it.
    if (config.mqtt.enabled) http_->context()->mqtt_link = std::make_shared<api::mqtt_link_state>();

    try {
        registry_->start();
    } catch (const std::exception& e) {
        log_->error("cannot start the simulated controllers: {}", e.what());
        return false;
    }
    jobs_->start();  // restart recovery: interrupted jobs, queued ones kept
    if (auto why = shares_->start(); !why.empty()) {
        log_->error("{}", why);
        stop_after_failed_start();
        return false;
    }
    try {
        http_->start();
    } catch (const std::exception& e) {
        log_->error("{}", e.what());
        stop_after_failed_start();
        return false;
    }
    // MQTT (mqtt.enabled): the fleet interface over the same API context as REST and WebSocket.
    if (config.mqtt.enabled) {
        api::mqtt_bridge_settings mqtt_settings;
        mqtt_settings.config = config.mqtt;
        mqtt_settings.gateway_id = api::resolve_gateway_id(config.mqtt.gateway_id, host_name());
        mqtt_settings.public_url = config.http.public_url;
        mqtt_settings.log = get_logger("mqtt");
        mqtt_ = api::mqtt_bridge::create(http_->context(), std::move(mqtt_settings));
        try {
            mqtt_->start();
        } catch (const std::exception& e) {
            log_->error("{}", e.what());
            stop_after_failed_start();
            return false;
        }
    }
    log_->info("asi-gateway {} {}", version,
               startup_summary(http_url(http_->local_endpoint(), tls_ != nullptr), config.storage.path,
                               registry_->list(),
                               config.mqtt.enabled ? config.mqtt.brokers : std::vector<std::string>{},
                               shares_->places()));
    return true;
}

// A late start step (HTTP, MQTT) failed: what started stops before run() returns 1. The I/O thread has
// not run yet, so nothing has moved: the ports close without HALT, and the job manager, which has only
// read the store, is abandoned by its destructor like a crash (what it stored stays as it was).
void application::stop_after_failed_start() {
    shares_->stop();
    http_->stop();
    registry_->stop();
    hub_->stop();
}

// The order in which the gateway stops: no new requests; running jobs HALTed, TTL low, interrupted and
// stored; recordings stopped (their trigger input modes put back) and stored; the controllers (HALTed when
// shutdown.halt_on_exit); MQTT, which publishes "offline" itself; last the hub, after the jobs' and
// controllers' final events have gone out.
void application::shutdown() {
    http_->stop();
    shares_->stop();
    run_in_order(std::make_shared<std::vector<step>>(std::vector<step>{
        [this](auto next) {
            jobs_->async_shutdown([this, next = std::move(next)] {
                jobs_work_.reset();  // the jobs thread ends once its last handler has run
                next();
            });
        },
        [this](auto next) { recorder_->shutdown(std::move(next)); },
        [this](auto next) { registry_->async_shutdown(std::move(next)); },
        [this](auto next) {
            if (mqtt_)
                mqtt_->async_stop(std::move(next));
            else
                next();
        },
        [this](auto) {
            hub_->stop();
            watchdog_ = std::thread([this] {
                std::unique_lock lock(mutex_);
                if (!finished_cv_.wait_for(lock, std::chrono::seconds(2), [this] { return finished_; }))
                    ioc_.stop();
            });
        },
    }));
}

void application::serve() {
    run_logging_exceptions(ioc_);
}

// One handler that throws must not take every controller, job and client down: log and go on.
void application::run_logging_exceptions(boost::asio::io_context& io) {
    for (;;) {
        try {
            io.run();
            return;
        } catch (const std::exception& e) {
            log_->critical("unhandled exception in an I/O handler, continuing: {}", e.what());
        }
    }
}

}  // namespace gw
