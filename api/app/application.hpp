#pragma once
// The composition root: the one object that sees every layer. It owns the services (controller
// registry, event hub, leases, job manager, HTTP/WebSocket server, MQTT bridge) on one io_context,
// starts them in dependency order, runs until SIGINT/SIGTERM (SIGHUP reloads the TLS certificate), and stops
// them in one readable order. The job manager works on a second thread of its own: its store commits wait for
// the disk (fsync), which must not stall the I/O thread.
//
//   gw::application app(std::move(launch));
//   return app.run();  // 0 after a clean stop, 1 when a service could not start

#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>

#include "api/app/command_line.hpp"
#include "gateway/storage/storage_lock.hpp"

namespace spdlog {
class logger;
}

namespace gw {

class controller_state_texts;
class event_hub;
class lease_manager;
class shared_ports;
class metrics;
namespace jobs {
class job_manager;
}
namespace recordings {
class recorder;
}
namespace api {
class server;
class mqtt_bridge;
class tls_server_context;
}  // namespace api

// An io_context that can drop what is still queued on it (shutdown()) before it is destroyed. The
// application has two whose leftovers hold each other's I/O objects (a handler on the jobs thread holds
// the job manager, which holds the event hub and its timers on the I/O thread's context; a reply
// pending on the I/O thread holds a job's coroutine and its timers on the jobs thread's context), so
// both are shut down before either is destroyed.
// Each is run by one thread: the hint lets Asio queue a handler posted from that thread without
// waking another.
class application_io_context : public boost::asio::io_context {
  public:
    application_io_context() : boost::asio::io_context(1) {}
    using boost::asio::execution_context::shutdown;
};

class application {
  public:
    explicit application(launch_settings launch);
    ~application();
    application(const application&) = delete;
    application& operator=(const application&) = delete;

    // Starts everything, serves until a signal has stopped it all, and returns the exit code.
    int run();

  private:
    bool start();
    void stop_after_failed_start();
    void shutdown();
    void serve();
    void wait_for_signal();
    // SIGHUP as a service: the TLS certificate read again, logged and audited.
    void reload_tls();
    // Runs `io` until it is stopped or out of work; a handler that throws is logged, not fatal.
    void run_logging_exceptions(boost::asio::io_context& io);

    launch_settings launch_;
    std::shared_ptr<spdlog::logger> log_;
    std::optional<storage_lock> storage_;  // held until every handler holding the store is gone
    application_io_context jobs_ioc_;      // the job manager's thread
    std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> jobs_work_;
    std::thread jobs_thread_;
    application_io_context ioc_;  // the I/O thread
    std::unique_ptr<controller_registry> registry_;
    std::shared_ptr<metrics> metrics_;
    std::shared_ptr<event_hub> hub_;
    std::shared_ptr<controller_state_texts> state_texts_;  // filled by the events bridge, read by HTTP
    std::shared_ptr<lease_manager> leases_;
    std::shared_ptr<jobs::job_manager> jobs_;
    std::unique_ptr<shared_ports> shares_;
    std::shared_ptr<recordings::recorder> recorder_;
    std::shared_ptr<api::tls_server_context> tls_;  // http.tls; null: plain HTTP
    std::unique_ptr<api::server> http_;
    std::shared_ptr<api::mqtt_bridge> mqtt_;
    // SIGINT, SIGTERM: a controlled stop (HALT to the stages it was moving, jobs interrupted, the store
    // closed). SIGHUP: a service (no terminal) reloads its TLS certificate; a gateway started from a
    // terminal stops, since then SIGHUP means the terminal closed and no one watches the stages.
    boost::asio::signal_set signals_{ioc_, SIGINT, SIGTERM, SIGHUP};
    bool from_terminal_ = false;  // stdin was a terminal at start

    // After shutdown, run() ends when the last handler has run; the watchdog (a thread, not a timer on
    // ioc_, which would itself keep run() going) stops it if something lingers.
    std::mutex mutex_;
    std::condition_variable finished_cv_;
    bool finished_ = false;
    std::thread watchdog_;
};

}  // namespace gw
