#include "api/mqtt/command_deadline.hpp"

namespace gw::api {

std::optional<command_deadline> earliest_deadline(const command_times& t, std::chrono::milliseconds max_age) {
    std::optional<command_deadline> earliest;
    auto consider = [&](std::int64_t at_ms, std::string_view source) {
        if (!earliest || at_ms < earliest->at_ms) earliest = command_deadline{at_ms, source};
    };
    if (t.expiry_s) consider(t.received_ms + std::int64_t{*t.expiry_s} * 1000, "message expiry");
    if (t.not_after_ms) consider(*t.not_after_ms, "not_after");
    if (t.signed_ts_ms) consider(*t.signed_ts_ms + max_age.count(), "ts + mqtt.commands.max_age_s");
    return earliest;
}

}  // namespace gw::api
