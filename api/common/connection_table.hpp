#pragma once
// The connection slots of http.limits, shared by every connection the listener accepts: at most
// max_connections in all and at most max_connections_per_address from one client address (never
// more than 7/8 of all slots: an address always leaves room for others). When every slot is taken,
// a newcomer is not turned away while a connection only waits: one is shed (closed) to make room.
// First the one that has waited longest for a request's header, then a keep-alive connection idle
// for longer than `patience`, then the one that has been reading a body for longest, if longer than
// `patience`; within each, the address that holds the most connections first. So connections that
// trickle a header (slowloris), never send one, or trickle a body cannot keep a slot from a client
// that sends its request at once. Connections being served (a request handled, a WebSocket) are
// never shed, and neither are a client between two requests or a body that came in less than
// `patience`.
// A HALT is never refused for want of a slot: a newcomer the limits would refuse gets one of
// `halt_reserve` slots kept apart (its permit is halt_only) where it may send a HALT, and nothing
// else (the session answers anything else 503 too-many-connections). When those are taken too, the
// one that has waited longest for its header is shed for it.
//
//   auto table = std::make_shared<connection_table>(connection_table::settings{256, 64, 5s});
//   auto a = table->admit(remote_address);   // a.permit null: refused (a.refusal says why)
//   if (auto victim = a.shed.lock()) victim->shed();
//   a.permit->track(session);                // the session reports its phase through the permit
//
// Thread-safe: the listener admits on its strand, sessions report from theirs.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "api/common/connection_permit.hpp"
#include "api/common/net.hpp"
#include "gateway/config/trusted_proxies.hpp"

namespace gw::api {

class connection_table : public std::enable_shared_from_this<connection_table> {
  public:
    using clock = std::chrono::steady_clock;

    struct settings {
        std::size_t max_connections = 256;
        std::size_t max_per_address = 64;
        std::chrono::milliseconds patience{5000};  // idleness or body reading that may be shed
        std::size_t halt_reserve = 8;              // slots beyond the limits, for a HALT alone
        // Reverse proxies speak for many clients: held to 7/8 of all slots, not to max_per_address.
        trusted_proxies proxies{};
    };

    enum class refusal : std::uint8_t { none, connection_limit, address_limit };

    struct admission {
        std::shared_ptr<connection_permit> permit;  // null: refused
        refusal refused = refusal::none;
        std::string detail;                      // why, for the 503 problem
        std::weak_ptr<tracked_connection> shed;  // the connection shed to make room: call shed()
        bool halt_only = false;                  // a reserve slot: `refused` and `detail` say why
    };

    explicit connection_table(settings s);

    admission admit(const net::ip::address& from, clock::time_point now = clock::now());

    std::size_t open() const;
    // What one address may hold (max_per_address, within 7/8 of max_connections).
    std::size_t per_address_limit() const { return per_address_; }
    // Closes every tracked connection (stop()).
    void close_all();

  private:
    friend class connection_permit;
    struct entry {
        net::ip::address address;
        connection_phase phase = connection_phase::awaiting_header;
        clock::time_point since;
        bool counted = true;     // false once shed: its slot went to the newcomer
        bool halt_only = false;  // a reserve slot: never counted, never shed for a normal slot
        std::weak_ptr<tracked_connection> connection;
    };

    void track(std::uint64_t id, std::weak_ptr<tracked_connection> c);
    void set_phase(std::uint64_t id, connection_phase phase);
    void release(std::uint64_t id);
    // The entry to shed for a newcomer, or entries_.end(). Called with mutex_ held.
    std::map<std::uint64_t, entry>::iterator pick_victim(clock::time_point now);
    // 0 sheds first; -1: not now.
    int shed_rank(const entry& e, clock::time_point now) const;
    void uncount(entry& e);
    // A reserve slot for a connection the limits refuse (`a` says why), shedding the reserve's oldest
    // connection still waiting for its header when all are taken. Called with mutex_ held.
    void admit_for_halt(admission& a, const net::ip::address& from, clock::time_point now);

    settings settings_;
    std::size_t per_address_;
    std::size_t per_proxy_;  // a trusted proxy's share
    mutable std::mutex mutex_;
    std::uint64_t next_id_ = 1;
    std::size_t open_ = 0;          // counted entries
    std::size_t reserve_open_ = 0;  // halt_only entries
    std::map<std::uint64_t, entry> entries_;
    std::map<net::ip::address, std::size_t> per_address_open_;
};

}  // namespace gw::api
