#include "api/ws/batch_text_cache.hpp"

#include <algorithm>

#include "api/ws/websocket_protocol.hpp"

namespace gw::api {

namespace {

bool same_events(const std::vector<std::shared_ptr<const event>>& a,
                 const std::vector<std::shared_ptr<const event>>& b) {
    return std::equal(a.begin(), a.end(), b.begin(), b.end(),
                      [](const auto& x, const auto& y) { return x.get() == y.get(); });
}

}  // namespace

std::shared_ptr<const std::string> batch_text_cache::text(
    const std::vector<std::shared_ptr<const event>>& events) {
    {
        std::lock_guard lock(mutex_);
        for (const auto& e : recent_)
            if (e.text && same_events(e.events, events)) return e.text;
    }
    // Built outside the lock: another session may build the same text meanwhile, which costs only
    // that copy.
    auto built = std::make_shared<const std::string>(ws_batch_message(events));
    std::lock_guard lock(mutex_);
    recent_[next_slot_] = {events, built};
    next_slot_ = (next_slot_ + 1) % slots;
    return built;
}

}  // namespace gw::api
