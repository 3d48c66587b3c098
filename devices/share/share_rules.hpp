#pragma once
// What a shared port's client may send, and the error replies the gateway gives in the controller's own
// form (":N-<code>" CR LF) when it refuses a line. The codes lie outside the firmware's documented ones
// (-1..-39), so a client's log tells a gateway refusal from the controller's. Pure.

#include <optional>
#include <string>
#include <string_view>

#include "devices/ms2000/command.hpp"
#include "devices/share/share_settings.hpp"

namespace gw::devices::share {

enum class refusal_code : int {
    held_elsewhere = -90,  // another party holds the controller's lease, or a job runs on it
    role = -91,            // the shared port's role does not allow the command
    unreadable = -92,      // not a command: too long, a byte outside printable ASCII, not a verb
    busy = -93,            // the gateway's queue for the controller is full
};

struct refusal {
    refusal_code code;
    std::string reason;  // for the log and the port's status, never sent to the client
};

// The bytes a client receives for a refused line: ":N-90\r\n".
std::string refusal_reply(refusal_code code);

// Whether `role` may send a command of this effect.
bool role_allows(share_role role, ms2000::command_effect effect);

// Whether a command of this effect needs the controller undisturbed (refused while someone else holds
// the lease or a job runs): everything but reads and HALT.
bool needs_control(ms2000::command_effect effect);

}  // namespace gw::devices::share
