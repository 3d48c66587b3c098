#pragma once
// Every controller's shared port (devices/share): the configured ones (controllers[].share) and, with
// simulate.share, a pty next to each simulated controller's port. Made by the composition root after
// the registry, started after the controllers, stopped first at shutdown (no legacy program's command
// goes out while the gateway stops its stages).
//
// Thread-safe: status() from any thread.

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/any_io_executor.hpp>

#include "devices/share/share_settings.hpp"
#include "devices/share/share_status.hpp"

namespace spdlog {
class logger;
}

namespace gw::devices::share {
class shared_port;
}

namespace gw {

class controller_registry;
class lease_and_job_gate;
class lease_manager;
struct gateway_config;

namespace jobs {
class job_manager;
}
namespace audit {
class audit_log;
}

class shared_ports {
  public:
    shared_ports(const boost::asio::any_io_executor& executor, const gateway_config& config,
                 controller_registry& registry, std::shared_ptr<lease_manager> leases,
                 std::shared_ptr<jobs::job_manager> jobs);
    ~shared_ports();
    shared_ports(const shared_ports&) = delete;
    shared_ports& operator=(const shared_ports&) = delete;

    // The audit trail for the shared clients' commands (call before start; null: none kept).
    void set_audit(std::shared_ptr<audit::audit_log> audit);
    // Opens every port; returns "" or why one could not be opened (the gateway does not start then).
    std::string start();
    void stop();

    // The controller's shared port, if it has one.
    std::optional<devices::share::port_status> status(const std::string& controller) const;
    std::vector<devices::share::port_status> all() const;
    // Controller id -> where its shared port is: "pty /run/x, tcp 127.0.0.1:7001, reports pty /run/y".
    std::map<std::string, std::string> places() const;

  private:
    std::shared_ptr<lease_and_job_gate> gate_;
    std::map<std::string, std::shared_ptr<devices::share::shared_port>> ports_;  // by controller id
    std::shared_ptr<spdlog::logger> log_;
};

// The share settings of simulated controllers: a pty at <directory of its port>/share, role admin (a
// simulator is there to be tried), for each of them.
std::vector<devices::share::share_settings> simulated_shares(const controller_registry& registry);

}  // namespace gw
