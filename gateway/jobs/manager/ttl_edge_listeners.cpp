#include "gateway/jobs/manager/ttl_edge_listeners.hpp"

namespace gw::jobs {

void ttl_edge_listeners::add(const std::string& controller) {
    std::lock_guard lock(mutex_);
    ++runs_[controller];
    ++total_;
}

void ttl_edge_listeners::remove(const std::string& controller) {
    std::lock_guard lock(mutex_);
    auto it = runs_.find(controller);
    if (it == runs_.end()) return;
    if (--it->second == 0) runs_.erase(it);
    --total_;
}

bool ttl_edge_listeners::listening(std::string_view controller) const {
    if (total_.load(std::memory_order_relaxed) == 0) return false;
    std::lock_guard lock(mutex_);
    return runs_.find(controller) != runs_.end();
}

}  // namespace gw::jobs
