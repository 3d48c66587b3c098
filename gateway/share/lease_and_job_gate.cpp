#include "gateway/share/lease_and_job_gate.hpp"

#include <fmt/format.h>
#include <utility>

#include <boost/asio/dispatch.hpp>
#include <spdlog/spdlog.h>

#include "gateway/audit/audit_log.hpp"
#include "gateway/common/timestamp.hpp"
#include "gateway/config/logging.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/jobs/manager/job_manager.hpp"
#include "gateway/leases/lease_manager.hpp"

namespace gw {

namespace net = boost::asio;
using devices::share::refusal;
using devices::share::refusal_code;

namespace {

std::string holder_name(const std::string& controller) {
    return "shared-port/" + controller;
}

}  // namespace

lease_and_job_gate::lease_and_job_gate(const net::any_io_executor& executor, controller_registry& registry,
                                       std::shared_ptr<lease_manager> leases,
                                       std::shared_ptr<jobs::job_manager> jobs)
    : strand_(net::make_strand(executor)),
      renewal_(strand_),
      registry_(registry),
      leases_(std::move(leases)),
      jobs_(std::move(jobs)),
      log_(get_logger("gateway")) {}

std::optional<refusal> lease_and_job_gate::admit(const std::string& controller) {
    std::optional<std::string> own_lease;
    {
        std::lock_guard lock(mutex_);
        if (auto it = held_leases_.find(controller); it != held_leases_.end()) own_lease = it->second;
    }
    if (jobs_) {
        if (auto hold = jobs_->holding(controller); hold && !(own_lease && hold->lease_id == own_lease))
            return refusal{refusal_code::held_elsewhere,
                           fmt::format("job {} is {} there", hold->job_id, jobs::to_string(hold->state))};
    }
    if (leases_) {
        auto allowed = leases_->check(controller,
                                      own_lease ? std::optional<std::string_view>(*own_lease) : std::nullopt);
        if (!allowed) return refusal{refusal_code::held_elsewhere, allowed.error().message};
    }
    return std::nullopt;
}

void lease_and_job_gate::record(const std::string& controller,
                                const devices::share::shared_command_record& r) {
    if (!audit_) return;
    audit::audit_entry e;
    e.time_ms = epoch_ms(std::chrono::system_clock::now());
    e.principal = "shared-port";
    e.role = devices::share::to_string(r.role);
    e.transport = "share";
    // "tcp 127.0.0.1:50412": the client's address; a pty client has none.
    if (r.client.starts_with("tcp ")) {
        const auto endpoint = r.client.substr(4);
        const auto colon = endpoint.rfind(':');
        e.address = endpoint.substr(0, colon);
        if (e.address.size() > 2 && e.address.front() == '[')
            e.address = e.address.substr(1, e.address.size() - 2);
    }
    e.action = r.halt ? "halt" : "command";
    e.controller = controller;
    e.request_id = r.client;
    const bool refused = r.outcome != "ok" && r.outcome != "controller-error" && r.outcome != "no-answer";
    e.status = r.outcome == "ok" ? 200 : refused ? (r.outcome == "forbidden" ? 403 : 409) : 502;
    e.outcome = r.outcome;
    e.detail = audit::bounded_detail({{"command", r.command}, {"client", r.client}});
    if (!r.reason.empty()) e.detail["reason"] = r.reason;
    audit_->record(std::move(e));
}

void lease_and_job_gate::halting(const std::string& controller, const std::string& client) {
    registry_.latch_halt(controller, holder_name(controller) + " (" + client + ")", "share");
}

bool lease_and_job_gate::clients_changed(const std::string& controller, std::size_t connected) {
    if (!leases_) return false;
    std::lock_guard lock(mutex_);
    if (stopped_) return false;
    if (connected == 0) {
        connected_.erase(controller);
        broken_.erase(controller);
        if (auto it = held_leases_.find(controller); it != held_leases_.end()) {
            leases_->release(controller, it->second, false);
            log_->info("{}: the shared port released its lease (no client connected)", controller);
            held_leases_.erase(it);
        }
        return false;
    }
    connected_[controller] = connected;
    broken_.erase(controller);
    const bool held = held_leases_.contains(controller) || take_lease(controller);
    if (!renewing_) {
        renewing_ = true;
        net::dispatch(strand_, [self = shared_from_this()] { self->arm_renewal(); });
    }
    return held;
}

bool lease_and_job_gate::take_lease(const std::string& controller) {
    auto taken = leases_->acquire(controller, holder_name(controller), lease_ttl);
    if (!taken) {
        log_->warn("{}: the shared port cannot take the lease while a client is connected: {}", controller,
                   taken.error().message);
        return false;
    }
    log_->info("{}: the shared port holds the lease while a client is connected", controller);
    held_leases_[controller] = taken->id;
    return true;
}

void lease_and_job_gate::arm_renewal() {
    renewal_.expires_after(lease_ttl / 3);
    renewal_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
        if (ec) return;
        self->renew_all();
        self->arm_renewal();
    });
}

void lease_and_job_gate::renew_all() {
    std::lock_guard lock(mutex_);
    if (stopped_) return;
    for (const auto& [controller, count] : connected_) {
        auto it = held_leases_.find(controller);
        if (it == held_leases_.end()) {
            if (!broken_.contains(controller)) take_lease(controller);  // someone else held it: try again
            continue;
        }
        if (!leases_->renew(controller, it->second, lease_ttl)) {
            // An admin broke it: the port does not take it back until a client connects again.
            log_->warn("{}: the shared port's lease ended (broken by an admin?)", controller);
            held_leases_.erase(it);
            broken_.insert(controller);
        }
    }
}

void lease_and_job_gate::stop() {
    std::lock_guard lock(mutex_);
    stopped_ = true;
    for (const auto& [controller, id] : held_leases_)
        if (leases_) leases_->release(controller, id, false);
    held_leases_.clear();
    net::dispatch(strand_, [self = shared_from_this()] { self->renewal_.cancel(); });
}

}  // namespace gw
