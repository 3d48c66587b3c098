#pragma once
// A controller's one way out, shared by its parts: the observer's callbacks (each caught, so that an
// observer's fault never reaches the link), the snapshot (published only when its content changed), and
// the driver's error messages (rate-limited). Used on the controller's strand only.

#include <chrono>
#include <exception>
#include <memory>
#include <optional>
#include <string>

#include <boost/system/error_code.hpp>

#include "devices/serial/controller_events.hpp"
#include "devices/serial/controller_observer.hpp"
#include "devices/serial/controller_snapshot.hpp"
#include "devices/serial/log_limiter.hpp"

namespace spdlog {
class logger;
}

namespace gw::devices {

class event_outlet {
  public:
    // `snapshot` is the controller's: its parts change it, publish_snapshot() shows it.
    event_outlet(std::string controller_id, controller_snapshot& snapshot, spdlog::logger& log,
                 std::weak_ptr<controller_observer> observer);

    void set_observer(std::weak_ptr<controller_observer> observer);

    // Stamps `updated` and publishes the snapshot, if its content changed since the last one published.
    void publish_snapshot();
    void report(const report_event& event);
    void ttl(const ttl_event& event);
    void error_log(const error_log_event& event);
    // One finished command; escaped here, and only when an observer listens.
    void trace(const std::string& request_id, bool internal, const std::string& wire, const std::string& raw,
               boost::system::error_code ec, std::chrono::microseconds latency);
    void fault(link_fault::kind kind);
    // "<what>: <message>", rate-limited: a port that keeps failing must not flood the log.
    void log_error(const char* what, boost::system::error_code ec);
    // An exception from the driver's own handling of this controller's input: logged and counted. The
    // caller resets the connection, so that no half-updated state is used.
    void contained(const char* where, const std::exception& e);

  private:
    template <typename Notify>
    void notify(const char* what, Notify&& call);

    std::string id_;
    controller_snapshot& snapshot_;
    spdlog::logger& log_;
    std::weak_ptr<controller_observer> observer_;
    std::optional<controller_snapshot> published_;
    log_limiter error_limiter_;
};

}  // namespace gw::devices
