#include "gateway/leases/lease_manager.hpp"

#include <fmt/format.h>
#include <utility>

#include "gateway/common/job_id.hpp"
#include "gateway/common/timestamp.hpp"

namespace gw {

namespace {

operation_result<void> check_ttl(std::chrono::seconds ttl) {
    if (ttl < min_lease_ttl || ttl > max_lease_ttl)
        return make_error(operation_error_kind::invalid_value,
                          fmt::format("ttl_s must be {}..{} (got {})", min_lease_ttl.count(),
                                      max_lease_ttl.count(), ttl.count()),
                          "ttl_s");
    return {};
}

}  // namespace

lease_manager::lease_manager(lease_clock clock) : clock_(std::move(clock)) {}

std::chrono::system_clock::time_point lease_manager::now() const {
    return clock_ ? clock_() : std::chrono::system_clock::now();
}

// Caller holds mutex_. A lease is over at its expiry instant.
void lease_manager::drop_expired(const std::string& controller) const {
    auto it = leases_.find(controller);
    if (it != leases_.end() && it->second.expires <= now()) leases_.erase(it);
}

operation_result<lease> lease_manager::acquire(const std::string& controller, std::string holder,
                                               std::chrono::seconds ttl) {
    if (auto r = check_ttl(ttl); !r) return r.error();
    std::lock_guard lock(mutex_);
    drop_expired(controller);
    if (auto it = leases_.find(controller); it != leases_.end())
        return make_error(operation_error_kind::leased,
                          fmt::format("controller {} is leased by {} until {}", controller, it->second.holder,
                                      format_timestamp(it->second.expires)));
    auto t = now();
    lease l{.id = jobs::make_lease_id(),
            .controller = controller,
            .holder = std::move(holder),
            .acquired = t,
            .expires = t + ttl};
    leases_[controller] = l;
    return l;
}

operation_result<lease> lease_manager::renew(const std::string& controller, std::string_view lease_id,
                                             std::chrono::seconds ttl) {
    if (auto r = check_ttl(ttl); !r) return r.error();
    std::lock_guard lock(mutex_);
    drop_expired(controller);
    auto it = leases_.find(controller);
    if (it == leases_.end() || it->second.id != lease_id)
        return make_error(
            operation_error_kind::invalid_state,
            fmt::format("no lease {} on controller {} (expired or released?)", lease_id, controller));
    it->second.expires = now() + ttl;
    return it->second;
}

operation_result<lease> lease_manager::release(const std::string& controller, std::string_view lease_id,
                                               bool force) {
    std::lock_guard lock(mutex_);
    drop_expired(controller);
    auto it = leases_.find(controller);
    if (it == leases_.end())
        return make_error(operation_error_kind::invalid_state,
                          fmt::format("controller {} is not leased", controller));
    if (!force && it->second.id != lease_id)
        return make_error(operation_error_kind::invalid_state,
                          fmt::format("lease {} is not the lease on controller {}", lease_id, controller));
    auto l = std::move(it->second);
    leases_.erase(it);
    return l;
}

std::optional<lease> lease_manager::current(const std::string& controller) const {
    std::lock_guard lock(mutex_);
    drop_expired(controller);
    auto it = leases_.find(controller);
    if (it == leases_.end()) return std::nullopt;
    return it->second;
}

std::vector<lease> lease_manager::all() const {
    std::lock_guard lock(mutex_);
    std::erase_if(leases_, [t = now()](const auto& entry) { return entry.second.expires <= t; });
    std::vector<lease> out;
    out.reserve(leases_.size());
    for (const auto& [controller, l] : leases_)
        out.push_back(l);
    return out;
}

operation_result<void> lease_manager::check(const std::string& controller,
                                            std::optional<std::string_view> lease_id) const {
    std::lock_guard lock(mutex_);
    drop_expired(controller);
    auto it = leases_.find(controller);
    if (it == leases_.end() || (lease_id && *lease_id == it->second.id)) return {};
    return make_error(operation_error_kind::leased,
                      fmt::format("controller {} is leased by {} until {}{}", controller, it->second.holder,
                                  format_timestamp(it->second.expires),
                                  lease_id ? " (the Lease-Id given is not that lease)" : ""));
}

}  // namespace gw
