#include "api/common/connection_table.hpp"

#include <algorithm>

namespace gw::api {

connection_table::connection_table(settings s)
    : settings_(std::move(s)),
      per_address_(
          std::min(settings_.max_per_address,
                   std::max<std::size_t>(1, settings_.max_connections - settings_.max_connections / 8))),
      per_proxy_(std::max<std::size_t>(1, settings_.max_connections - settings_.max_connections / 8)) {}

connection_table::admission connection_table::admit(const net::ip::address& from, clock::time_point now) {
    admission a;
    std::lock_guard lock(mutex_);
    const auto limit = settings_.proxies.contains(from) ? per_proxy_ : per_address_;
    if (auto it = per_address_open_.find(from); it != per_address_open_.end() && it->second >= limit) {
        a.refused = refusal::address_limit;
        a.detail = from.to_string() + " has " + std::to_string(it->second) +
                   " connections open, the most one address may; try again later (a HALT is still served)";
        admit_for_halt(a, from, now);
        return a;
    }
    if (open_ >= settings_.max_connections) {
        auto victim = pick_victim(now);
        if (victim == entries_.end()) {
            a.refused = refusal::connection_limit;
            a.detail = "the gateway has " + std::to_string(open_) +
                       " connections open; try again later (a HALT is still served)";
            admit_for_halt(a, from, now);
            return a;
        }
        uncount(victim->second);
        a.shed = victim->second.connection;
    }
    const auto id = next_id_++;
    entries_.emplace(id, entry{from, connection_phase::awaiting_header, now, true, false, {}});
    ++open_;
    ++per_address_open_[from];
    a.permit = std::make_shared<connection_permit>(shared_from_this(), id);
    return a;
}

void connection_table::admit_for_halt(admission& a, const net::ip::address& from, clock::time_point now) {
    if (reserve_open_ >= settings_.halt_reserve) {
        auto oldest = entries_.end();
        for (auto it = entries_.begin(); it != entries_.end(); ++it)
            if (it->second.halt_only && it->second.counted &&
                it->second.phase == connection_phase::awaiting_header &&
                (oldest == entries_.end() || it->second.since < oldest->second.since))
                oldest = it;
        if (oldest == entries_.end()) return;  // every reserve slot serves a HALT right now
        uncount(oldest->second);               // its slot goes to the newcomer
        a.shed = oldest->second.connection;
    }
    const auto id = next_id_++;
    entry e{from, connection_phase::awaiting_header, now, true, true, {}};
    entries_.emplace(id, std::move(e));
    ++reserve_open_;
    a.halt_only = true;
    a.permit = std::make_shared<connection_permit>(shared_from_this(), id, true);
}

std::map<std::uint64_t, connection_table::entry>::iterator connection_table::pick_victim(
    clock::time_point now) {
    auto best = entries_.end();
    int best_rank = 0;
    std::size_t best_count = 0;
    for (auto it = entries_.begin(); it != entries_.end(); ++it) {
        const auto& e = it->second;
        const int rank = shed_rank(e, now);
        if (rank < 0) continue;
        const auto count = per_address_open_.at(e.address);
        // The lowest rank, then the busiest address, then the longest wait.
        if (best == entries_.end() || rank < best_rank || (rank == best_rank && count > best_count) ||
            (rank == best_rank && count == best_count && e.since < best->second.since)) {
            best = it;
            best_rank = rank;
            best_count = count;
        }
    }
    return best;
}

int connection_table::shed_rank(const entry& e, clock::time_point now) const {
    if (!e.counted || e.halt_only) return -1;
    const bool patience_over = now - e.since >= settings_.patience;
    switch (e.phase) {
        case connection_phase::closing:  // its answer is out: nothing is lost by closing it now
            return 0;
        case connection_phase::awaiting_header:
            return 1;
        case connection_phase::idle:
            return patience_over ? 2 : -1;
        case connection_phase::reading_body:
            return patience_over ? 3 : -1;
        case connection_phase::serving:
            break;
    }
    return -1;
}

void connection_table::uncount(entry& e) {
    if (!e.counted) return;
    e.counted = false;
    if (e.halt_only) {
        --reserve_open_;
        return;
    }
    --open_;
    auto it = per_address_open_.find(e.address);
    if (--it->second == 0) per_address_open_.erase(it);
}

std::size_t connection_table::open() const {
    std::lock_guard lock(mutex_);
    return open_;
}

void connection_table::close_all() {
    std::vector<std::weak_ptr<tracked_connection>> all;
    {
        std::lock_guard lock(mutex_);
        for (const auto& [id, e] : entries_)
            all.push_back(e.connection);
    }
    for (auto& w : all)
        if (auto c = w.lock()) c->close();
}

void connection_table::track(std::uint64_t id, std::weak_ptr<tracked_connection> c) {
    std::lock_guard lock(mutex_);
    if (auto it = entries_.find(id); it != entries_.end()) it->second.connection = std::move(c);
}

void connection_table::set_phase(std::uint64_t id, connection_phase phase) {
    std::lock_guard lock(mutex_);
    if (auto it = entries_.find(id); it != entries_.end()) {
        it->second.phase = phase;
        it->second.since = clock::now();
    }
}

void connection_table::release(std::uint64_t id) {
    std::lock_guard lock(mutex_);
    auto it = entries_.find(id);
    if (it == entries_.end()) return;
    uncount(it->second);
    entries_.erase(it);
}

connection_permit::~connection_permit() {
    table_->release(id_);
}

void connection_permit::track(std::weak_ptr<tracked_connection> c) {
    table_->track(id_, std::move(c));
}

void connection_permit::set_phase(connection_phase phase) {
    table_->set_phase(id_, phase);
}

}  // namespace gw::api
