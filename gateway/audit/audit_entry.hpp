#pragma once
// One line of the audit trail: who changed what, when, through which transport, and how it ended.
// Written for every state-changing call (api/calls/calls.hpp) and G-code upload or delete, from any
// transport; read back by GET /api/v1/audit (admin).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace gw::audit {

struct audit_entry {
    std::int64_t id = 0;       // given by the store, increasing
    std::int64_t time_ms = 0;  // Unix epoch, the gateway's clock when the call ended
    std::string principal;     // the token's or signing key's name, "anonymous" without tokens
    std::string role;          // viewer, operator, admin
    std::string transport;     // rest, websocket, mqtt
    std::string address;       // the client's address ("" for MQTT: the broker relays)
    std::string action;        // "move", "command", "job.submit", "job.cancel", "lease.take", "halt_all", ...
    std::string controller;    // "" when the call names none (HALT ALL, a job action)
    std::string target;        // the job or G-code file the call names, "" when none
    std::string request_id;
    int status = 200;       // the HTTP status of the outcome (200/201 done, 4xx refused, 5xx failed)
    std::string outcome;    // "ok", or the problem's type name ("forbidden", "controller-error", ...)
    nlohmann::json detail;  // the call's arguments, at most max_detail_bytes of JSON text (else a note)
};

inline constexpr std::size_t max_detail_bytes = 2048;

// The arguments as kept: `args` itself when its JSON text fits max_detail_bytes, else
// {"truncated": true, "bytes": N}.
nlohmann::json bounded_detail(const nlohmann::json& args);

struct audit_filter {
    std::optional<std::string> controller;
    std::optional<std::string> principal;
    std::optional<std::int64_t> since_ms;   // time_ms >= since
    std::optional<std::int64_t> until_ms;   // time_ms < until
    std::optional<std::int64_t> before_id;  // paging: entries older than this id
    std::size_t limit = 100;                // 1..500
};

struct audit_page {
    std::vector<audit_entry> entries;         // newest first
    std::optional<std::int64_t> next_before;  // the cursor of the next page, when there may be one
};

nlohmann::json to_json(const audit_entry& e);
nlohmann::json to_json(const audit_page& p);

}  // namespace gw::audit
