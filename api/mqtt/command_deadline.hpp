#pragma once
// When an MQTT command may no longer run. A command can wait where the gateway does not see it: in a
// bridge's queue while a site broker is away, in a persistent session, in a QoS 1 redelivery after a
// failover. Run then, a move would start minutes after the sender gave up on it. So a command that
// changes something carries a deadline, and one that arrives after it is refused (stale-command),
// never run. Pure.
//
// The deadline is the earliest of what the command says:
//   - MQTT 5 message expiry: the interval the broker delivered (what was left of the sender's), from
//     when the client library handed the message over;
//   - "not_after" in the payload: Unix milliseconds of the sender's clock;
//   - a signed command's "ts" plus mqtt.commands.max_age_s.

#include <chrono>
#include <cstdint>
#include <optional>
#include <string_view>

namespace gw::api {

struct command_deadline {
    std::int64_t at_ms = 0;   // Unix milliseconds
    std::string_view source;  // "message expiry", "not_after", "ts + mqtt.commands.max_age_s"
};

struct command_times {
    std::int64_t received_ms = 0;              // when the client library handed the message over
    std::optional<std::uint32_t> expiry_s;     // MQTT 5 message expiry interval, as delivered
    std::optional<std::int64_t> not_after_ms;  // the payload's "not_after"
    std::optional<std::int64_t> signed_ts_ms;  // a signed envelope's "ts"
};

// The earliest deadline the command carries; nullopt when it carries none.
std::optional<command_deadline> earliest_deadline(const command_times& t, std::chrono::milliseconds max_age);

}  // namespace gw::api
