#include "api/mqtt/replay_window.hpp"

#include <algorithm>

namespace gw::api {

replay_window::verdict replay_window::admit(const std::string& key, const std::string& nonce,
                                            std::int64_t ts_ms, std::int64_t now_ms) {
    const auto window = window_.count();
    if (ts_ms < now_ms - window || ts_ms > now_ms + window) return verdict::stale;
    // A pair is remembered until no command carrying it can be fresh again: its ts plus the window.
    forget_before(now_ms);
    auto pair = std::make_pair(key, nonce);
    if (seen_.contains(pair)) return verdict::replayed;
    if (seen_.size() >= max_entries_) return verdict::full;
    seen_.insert(pair);
    const auto expires = ts_ms + window;
    // Kept in expiry order: admitted ts values lie within the window of a clock that only moves on,
    // so an entry is inserted where its expiry belongs (usually at the back).
    auto at = std::upper_bound(by_expiry_.begin(), by_expiry_.end(), expires,
                               [](std::int64_t e, const auto& entry) { return e < entry.first; });
    by_expiry_.insert(at, {expires, std::move(pair)});
    return verdict::fresh;
}

void replay_window::forget_before(std::int64_t cutoff_ms) {
    while (!by_expiry_.empty() && by_expiry_.front().first < cutoff_ms) {
        seen_.erase(by_expiry_.front().second);
        by_expiry_.pop_front();
    }
}

}  // namespace gw::api
