#include "api/calls/share_json.hpp"

#include "api/common/api_context.hpp"
#include "gateway/common/metrics.hpp"
#include "gateway/common/timestamp.hpp"
#include "gateway/share/shared_ports.hpp"

namespace gw::api {

namespace {

nlohmann::json text_or_null(const std::string& text) {
    return text.empty() ? nlohmann::json(nullptr) : nlohmann::json(text);
}

nlohmann::json clients_json(const std::vector<devices::share::client_status>& clients) {
    auto out = nlohmann::json::array();
    for (const auto& c : clients)
        out.push_back({{"name", c.name},
                       {"since", format_timestamp(c.since)},
                       {"commands", c.commands},
                       {"refused", c.refused},
                       {"dropped_bytes", c.dropped_bytes},
                       {"late", c.late}});
    return out;
}

}  // namespace

nlohmann::json share_json(const devices::share::port_status& s) {
    return {{"pty", text_or_null(s.pty)},
            {"tcp", text_or_null(s.tcp)},
            {"role", s.role},
            {"lease", s.lease},
            {"holds_lease", s.holds_lease},
            {"commands", s.commands},
            {"refused", s.refused},
            {"connections_refused", s.clients_refused},
            {"clients", clients_json(s.clients)},
            {"report_pty", text_or_null(s.report_pty)},
            {"report_tcp", text_or_null(s.report_tcp)},
            {"report_readers", clients_json(s.report_readers)}};
}

nlohmann::json share_json_of(const api_context& ctx, const std::string& controller) {
    if (!ctx.shares) return nullptr;
    auto s = ctx.shares->status(controller);
    return s ? share_json(*s) : nlohmann::json(nullptr);
}

void describe_share_metrics(const api_context& ctx) {
    auto& m = *ctx.metrics;
    m.describe("gw_share_clients", metric_type::gauge, "Programs connected to the controller's shared port");
    m.describe("gw_share_commands_total", metric_type::counter,
               "Lines of shared-port clients, by outcome: sent to the controller, or refused by the gateway");
    m.describe("gw_share_connections_refused_total", metric_type::counter,
               "Shared TCP connections closed at once because share.max_clients were connected");
}

void copy_share_counters(const api_context& ctx) {
    if (!ctx.shares) return;
    auto& m = *ctx.metrics;
    for (const auto& s : ctx.shares->all()) {
        const metric_labels id{{"controller", s.controller}};
        m.set("gw_share_clients", id, static_cast<double>(s.clients.size()));
        m.set("gw_share_commands_total", {{"controller", s.controller}, {"outcome", "sent"}},
              static_cast<double>(s.commands));
        m.set("gw_share_commands_total", {{"controller", s.controller}, {"outcome", "refused"}},
              static_cast<double>(s.refused));
        m.set("gw_share_connections_refused_total", id, static_cast<double>(s.clients_refused));
    }
}

}  // namespace gw::api
