#include "api/calls/call_audit.hpp"

#include <chrono>
#include <string>

#include "gateway/common/timestamp.hpp"
#include "gateway/config/config.hpp"

namespace gw::api {

namespace {

std::string string_field(const nlohmann::json& j, const char* key) {
    if (!j.is_object()) return {};
    const auto it = j.find(key);
    return it != j.end() && it->is_string() ? it->get<std::string>() : std::string();
}

// An entry with who, from where and under which request id; the rest is the caller's to fill in.
audit::audit_entry entry_by(const caller& who) {
    audit::audit_entry e;
    e.principal = who.name;
    e.role = std::string(to_string(who.role));
    e.transport = who.transport;
    e.address = who.address;
    e.request_id = who.request_id;
    return e;
}

}  // namespace

std::optional<audit::audit_entry> audit_entry_for(const caller& who, const call& c) {
    const auto& kind = descriptor_of(c);
    if (!kind.audited) return std::nullopt;  // reads, renewals, dry runs, G-code checks
    auto e = entry_by(who);
    e.action = std::string(kind.name);
    if (const auto* op = std::get_if<operation_call>(&c)) {
        e.action = op->operation;  // also an operation that does not exist (its 404 is recorded)
        e.controller = op->controller;
        e.detail = audit::bounded_detail(op->args);
    } else if (const auto* submit = std::get_if<job_submit_call>(&c)) {
        e.controller = string_field(submit->request, "controller");
        e.detail = audit::bounded_detail(submit->request);
    } else if (const auto* action = std::get_if<job_action_call>(&c)) {
        e.target = action->job_id;
    } else if (const auto* take = std::get_if<lease_take_call>(&c)) {
        e.controller = take->controller;
        e.detail = audit::bounded_detail(take->body);
    } else if (const auto* release = std::get_if<lease_release_call>(&c)) {
        e.controller = release->controller;
    } else if (const auto* start = std::get_if<recording_start_call>(&c)) {
        e.controller = start->controller;
        e.detail = audit::bounded_detail(start->body);
    } else if (const auto* stop = std::get_if<recording_stop_call>(&c)) {
        e.target = stop->recording_id;
    } else if (const auto* remove = std::get_if<recording_delete_call>(&c)) {
        e.target = remove->recording_id;
    }
    if (e.detail.is_null()) e.detail = nlohmann::json::object();
    return e;
}

void complete_audit_entry(audit::audit_entry& e, const api_outcome& out, std::int64_t time_ms) {
    e.time_ms = time_ms;
    if (out.error) {
        e.status = static_cast<int>(out.error->status);
        e.outcome = out.error->kind.empty() ? "error" : out.error->kind;
        return;
    }
    e.status = static_cast<int>(out.status);
    e.outcome = "ok";
    if (e.action == "job.submit" || e.action == "recording.start") e.target = string_field(out.body, "id");
}

audit::audit_entry route_audit_entry(const caller& who, std::string action, std::string target,
                                     unsigned status) {
    auto e = entry_by(who);
    e.action = std::move(action);
    e.target = std::move(target);
    e.detail = nlohmann::json::object();
    e.status = static_cast<int>(status);
    e.outcome = status < 400 ? "ok" : status < 500 ? "refused" : "failed";
    e.time_ms = epoch_ms(std::chrono::system_clock::now());
    return e;
}

}  // namespace gw::api
