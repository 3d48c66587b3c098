#pragma once
// The gateway's rules for shared ports (devices::share::share_gate): a shared client's motion and
// setting commands are refused while another party holds the controller's lease or a job runs there; a
// shared client's HALT latches the controller as every HALT does (its jobs pause); with share.lease, the
// port holds the controller's lease while a client is connected, renewed until the last one leaves.
// What a shared client moves or changes (and its HALTs) goes into the audit trail like any call.
//
// Thread-safe: shared ports call it from their strands; the renewal runs on its own strand.

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>

#include "devices/share/share_gate.hpp"

namespace spdlog {
class logger;
}

namespace gw {

class controller_registry;
class lease_manager;

namespace jobs {
class job_manager;
}
namespace audit {
class audit_log;
}

class lease_and_job_gate : public devices::share::share_gate,
                           public std::enable_shared_from_this<lease_and_job_gate> {
  public:
    // The lease a port holds lives this long unless renewed; it is renewed every third of it.
    static constexpr std::chrono::seconds lease_ttl{60};

    lease_and_job_gate(const boost::asio::any_io_executor& executor, controller_registry& registry,
                       std::shared_ptr<lease_manager> leases, std::shared_ptr<jobs::job_manager> jobs);

    std::optional<devices::share::refusal> admit(const std::string& controller) override;
    void halting(const std::string& controller, const std::string& client) override;
    bool clients_changed(const std::string& controller, std::size_t connected) override;
    // Into the audit trail (when set_audit gave one): principal "shared-port", transport "share",
    // the client's address for a TCP client, action "command" (or "halt"), the line in the detail.
    void record(const std::string& controller, const devices::share::shared_command_record& r) override;

    // The audit trail; before the ports open (null: none kept).
    void set_audit(std::shared_ptr<audit::audit_log> audit) { audit_ = std::move(audit); }

    // Ends the renewals and releases every lease the ports hold.
    void stop();

  private:
    void renew_all();
    void arm_renewal();
    // Takes the lease for `controller` if it is free; the lock is held.
    bool take_lease(const std::string& controller);

    boost::asio::strand<boost::asio::any_io_executor> strand_;
    boost::asio::steady_timer renewal_;
    controller_registry& registry_;
    std::shared_ptr<lease_manager> leases_;
    std::shared_ptr<jobs::job_manager> jobs_;
    std::shared_ptr<spdlog::logger> log_;
    std::shared_ptr<audit::audit_log> audit_;

    std::mutex mutex_;
    std::map<std::string, std::size_t> connected_;    // controllers whose port wants the lease
    std::map<std::string, std::string> held_leases_;  // controller -> lease id the port holds
    std::set<std::string> broken_;  // an admin broke the port's lease: not taken back until a client connects
    bool renewing_ = false;
    bool stopped_ = false;
};

}  // namespace gw
