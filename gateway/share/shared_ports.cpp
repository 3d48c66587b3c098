#include "gateway/share/shared_ports.hpp"

#include <filesystem>
#include <utility>

#include <spdlog/spdlog.h>

#include "devices/share/shared_port.hpp"
#include "gateway/config/config.hpp"
#include "gateway/config/logging.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/share/lease_and_job_gate.hpp"

namespace gw {

std::vector<devices::share::share_settings> simulated_shares(const controller_registry& registry) {
    std::vector<devices::share::share_settings> shares;
    const auto* fleet = registry.fleet();
    if (!fleet) return shares;
    for (const auto& s : fleet->controller_settings()) {
        devices::share::share_settings share;
        share.controller = s.id;
        share.line_baud = s.baud;
        share.pty = (std::filesystem::path(s.port).parent_path() / "share").string();
        share.role = devices::share::share_role::admin;
        shares.push_back(std::move(share));
    }
    return shares;
}

shared_ports::shared_ports(const boost::asio::any_io_executor& executor, const gateway_config& config,
                           controller_registry& registry, std::shared_ptr<lease_manager> leases,
                           std::shared_ptr<jobs::job_manager> jobs)
    : gate_(std::make_shared<lease_and_job_gate>(executor, registry, std::move(leases), std::move(jobs))),
      log_(get_logger("gateway")) {
    auto shares = config.shares;
    if (config.simulate.share)
        for (auto& s : simulated_shares(registry))
            shares.push_back(std::move(s));
    for (auto& s : shares) {
        auto controller = registry.controller(s.controller);
        if (!controller) continue;  // validated with the config: cannot happen
        auto id = s.controller;
        ports_[id] = std::make_shared<devices::share::shared_port>(executor, std::move(s), controller, gate_);
    }
}

shared_ports::~shared_ports() {
    stop();
}

void shared_ports::set_audit(std::shared_ptr<audit::audit_log> audit) {
    gate_->set_audit(std::move(audit));
}

std::string shared_ports::start() {
    for (const auto& [id, port] : ports_) {
        if (auto why = port->start(); !why.empty()) return why.insert(0, id + ": ");
        const auto s = port->status();
        log_->info("{}: shared at {} (role {}{})", id, places().at(id), s.role,
                   s.lease ? ", takes the lease" : "");
    }
    return {};
}

std::map<std::string, std::string> shared_ports::places() const {
    std::map<std::string, std::string> out;
    for (const auto& [id, port] : ports_) {
        const auto s = port->status();
        std::vector<std::string> parts;
        if (!s.pty.empty()) parts.push_back("pty " + s.pty);
        if (!s.tcp.empty()) parts.push_back("tcp " + s.tcp);
        if (!s.report_pty.empty()) parts.push_back("reports pty " + s.report_pty);
        if (!s.report_tcp.empty()) parts.push_back("reports tcp " + s.report_tcp);
        std::string text;
        for (const auto& p : parts)
            text += (text.empty() ? "" : ", ") + p;
        out[id] = text;
    }
    return out;
}

void shared_ports::stop() {
    for (const auto& [id, port] : ports_)
        port->stop();
    gate_->stop();
}

std::optional<devices::share::port_status> shared_ports::status(const std::string& controller) const {
    auto it = ports_.find(controller);
    if (it == ports_.end()) return std::nullopt;
    return it->second->status();
}

std::vector<devices::share::port_status> shared_ports::all() const {
    std::vector<devices::share::port_status> out;
    for (const auto& [id, port] : ports_)
        out.push_back(port->status());
    return out;
}

}  // namespace gw
