#pragma once
// What a shared port asks of the gateway before a client's command goes to the controller: the rules
// that live above the devices layer (leases, jobs, the emergency stop's bookkeeping). gateway/share
// implements it. Called on the shared port's strand; implementations are thread-safe.

#include <cstddef>
#include <optional>
#include <string>

#include "devices/share/share_rules.hpp"

namespace gw::devices::share {

// A command of a shared client that moves or changes something, or a HALT, as it ended: for the
// gateway's audit trail. Queries are not reported.
struct shared_command_record {
    std::string client;   // "tcp 127.0.0.1:50412" or "pty"
    std::string command;  // the line as the client sent it
    share_role role;      // the port's share.role
    // "ok"; "controller-error" (its :N refusal) or "no-answer" (not connected, timed out, queue full);
    // or the gateway's refusal: "forbidden" (the role), "held-elsewhere" (a lease or a job), "late"
    std::string outcome;
    std::string reason;  // the refusal's reason, "" otherwise
    bool halt = false;   // the command is a HALT
};

class share_gate {
  public:
    virtual ~share_gate() = default;

    // Whether a command that moves or changes something may go now: nullopt, or why not (another party
    // holds the controller's lease, a job runs there).
    virtual std::optional<refusal> admit(const std::string& controller) = 0;
    // A client sent HALT: it stops the jobs there as any HALT does, before it is written.
    virtual void halting(const std::string& controller, const std::string& client) = 0;
    // A command that moves or changes something (or a HALT) ended, sent or refused.
    virtual void record(const std::string& controller, const shared_command_record& r) = 0;
    // The number of connected clients changed (share.lease takes the lease at the first, releases it
    // after the last). Returns whether the port holds the lease now.
    virtual bool clients_changed(const std::string& controller, std::size_t connected) = 0;
};

}  // namespace gw::devices::share
