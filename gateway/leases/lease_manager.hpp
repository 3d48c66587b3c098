#pragma once
// Exclusive leases on controllers. While a controller is leased, moves, jobs and other state-changing
// operations from anyone not presenting the lease id get operation_error_kind::leased (409) - the same
// rule for REST (header "Lease-Id"), WebSocket ({"lease": ...}) and MQTT (field "lease").
// A lease expires unless renewed; an admin may break one (release with force). Leases live in memory:
// a gateway restart ends them all (clients see 409 invalid-state on renew and take a new one).
//
// Thread-safe (one mutex); the clock is injectable for tests.

#include <chrono>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gateway/common/operation_error.hpp"

namespace gw {

using lease_clock = std::function<std::chrono::system_clock::time_point()>;

struct lease {
    std::string id;  // opaque, unguessable ("l-" + 32 hex characters); the proof of holding it
    std::string controller;
    std::string holder;  // who asked: principal plus an optional client label ("alice/notebook-3")
    std::chrono::system_clock::time_point acquired;
    std::chrono::system_clock::time_point expires;
};

inline constexpr std::chrono::seconds min_lease_ttl{1};
inline constexpr std::chrono::seconds max_lease_ttl{24 * 3600};
inline constexpr std::chrono::seconds default_lease_ttl{60};

class lease_manager {
  public:
    explicit lease_manager(lease_clock clock = {});

    // invalid_value for a ttl out of [min_lease_ttl, max_lease_ttl]; leased (409) when someone else
    // holds an unexpired lease on the controller. Does not check that the controller exists.
    operation_result<lease> acquire(const std::string& controller, std::string holder,
                                    std::chrono::seconds ttl);
    // Extends the lease by ttl from now. unknown lease id or expired: invalid_state.
    operation_result<lease> renew(const std::string& controller, std::string_view lease_id,
                                  std::chrono::seconds ttl);
    // Ends the lease. `force` (admin) ends it whatever the id. invalid_state when there is none / wrong id.
    operation_result<lease> release(const std::string& controller, std::string_view lease_id, bool force);
    // The unexpired lease on the controller, if any.
    std::optional<lease> current(const std::string& controller) const;
    // Every unexpired lease, by controller id.
    std::vector<lease> all() const;

    // Ok when the controller is not leased, or `lease_id` is its lease. Otherwise `leased`, with a
    // message naming the holder and the expiry time.
    operation_result<void> check(const std::string& controller,
                                 std::optional<std::string_view> lease_id) const;

  private:
    std::chrono::system_clock::time_point now() const;
    void drop_expired(const std::string& controller) const;

    lease_clock clock_;
    mutable std::mutex mutex_;
    mutable std::map<std::string, lease> leases_;  // by controller
};

}  // namespace gw
