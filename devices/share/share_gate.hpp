#pragma once
// What a shared port asks of the gateway before a client's command goes to the controller: the rules
// that live above the devices layer (leases, jobs, the emergency stop's bookkeeping). gateway/share
// implements it. Called on the shared port's strand; implementations are thread-safe.

#include <cstddef>
#include <optional>
#include <string>

#include "devices/share/share_rules.hpp"

namespace gw::devices::share {

class share_gate {
  public:
    virtual ~share_gate() = default;

    // Whether a command that moves or changes something may go now: nullopt, or why not (another party
    // holds the controller's lease, a job runs there).
    virtual std::optional<refusal> admit(const std::string& controller) = 0;
    // A client sent HALT: it stops the jobs there as any HALT does, before it is written.
    virtual void halting(const std::string& controller, const std::string& client) = 0;
    // The number of connected clients changed (share.lease takes the lease at the first, releases it
    // after the last). Returns whether the port holds the lease now.
    virtual bool clients_changed(const std::string& controller, std::size_t connected) = 0;
};

}  // namespace gw::devices::share
