#include "gateway/jobs/manager/job_lanes.hpp"

#include <algorithm>

namespace gw::jobs {

void job_lanes::enqueue(const std::string& controller, const std::string& id, bool first) {
    auto& l = lanes_[controller];
    if (first)
        l.queue.push_front(id);
    else
        l.queue.push_back(id);
}

void job_lanes::remove(const std::string& controller, const std::string& id) {
    if (auto it = lanes_.find(controller); it != lanes_.end()) std::erase(it->second.queue, id);
}

std::optional<std::string> job_lanes::take_next(const std::string& controller,
                                                const std::function<bool(const std::string&)>& still_queued) {
    auto& l = lanes_[controller];
    if (!l.holder.empty() || l.planning) return std::nullopt;
    while (!l.queue.empty()) {
        auto id = std::move(l.queue.front());
        l.queue.pop_front();
        if (!still_queued(id)) continue;
        l.holder = id;
        return id;
    }
    return std::nullopt;
}

void job_lanes::release(const std::string& controller, const std::string& id) {
    if (auto it = lanes_.find(controller); it != lanes_.end() && it->second.holder == id)
        it->second.holder.clear();
}

std::string job_lanes::holder(const std::string& controller) const {
    const auto* l = find(controller);
    return l ? l->holder : std::string();
}

void job_lanes::set_planning(const std::string& controller, bool planning) {
    lanes_[controller].planning = planning;
}

bool job_lanes::busy(const std::string& controller) const {
    const auto* l = find(controller);
    return l && (!l->holder.empty() || !l->queue.empty() || l->planning);
}

const std::deque<std::string>& job_lanes::queue(const std::string& controller) const {
    static const std::deque<std::string> none;
    const auto* l = find(controller);
    return l ? l->queue : none;
}

std::vector<std::string> job_lanes::controllers() const {
    std::vector<std::string> out;
    out.reserve(lanes_.size());
    for (const auto& [controller, l] : lanes_)
        out.push_back(controller);
    return out;
}

const job_lanes::lane* job_lanes::find(const std::string& controller) const {
    auto it = lanes_.find(controller);
    return it == lanes_.end() ? nullptr : &it->second;
}

}  // namespace gw::jobs
