#include "gateway/audit/audit_entry.hpp"

#include <chrono>

#include "gateway/common/timestamp.hpp"

namespace gw::audit {

nlohmann::json bounded_detail(const nlohmann::json& args) {
    if (args.is_null()) return nlohmann::json::object();
    const auto text = args.dump();
    if (text.size() <= max_detail_bytes) return args;
    return {{"truncated", true}, {"bytes", text.size()}};
}

nlohmann::json to_json(const audit_entry& e) {
    return {{"id", e.id},
            {"time",
             format_timestamp(std::chrono::system_clock::time_point(std::chrono::milliseconds(e.time_ms)))},
            {"principal", e.principal},
            {"role", e.role},
            {"transport", e.transport},
            {"address", e.address.empty() ? nlohmann::json() : nlohmann::json(e.address)},
            {"action", e.action},
            {"controller", e.controller.empty() ? nlohmann::json() : nlohmann::json(e.controller)},
            {"target", e.target.empty() ? nlohmann::json() : nlohmann::json(e.target)},
            {"request_id", e.request_id},
            {"status", e.status},
            {"outcome", e.outcome},
            {"detail", e.detail}};
}

nlohmann::json to_json(const audit_page& p) {
    nlohmann::json entries = nlohmann::json::array();
    for (const auto& e : p.entries)
        entries.push_back(to_json(e));
    return {{"entries", std::move(entries)},
            {"next_before", p.next_before ? nlohmann::json(*p.next_before) : nlohmann::json()}};
}

}  // namespace gw::audit
