#include "gateway/jobs/manager/job_holds.hpp"

namespace gw::jobs {

void job_holds::hold(const std::string& controller, job_hold job) {
    std::lock_guard lock(mutex_);
    holds_[controller] = std::move(job);
}

void job_holds::release(const std::string& controller, const std::string& job_id) {
    std::lock_guard lock(mutex_);
    if (auto it = holds_.find(controller); it != holds_.end() && it->second.job_id == job_id)
        holds_.erase(it);
}

std::optional<job_hold> job_holds::find(const std::string& controller) const {
    std::lock_guard lock(mutex_);
    auto it = holds_.find(controller);
    if (it == holds_.end()) return std::nullopt;
    return it->second;
}

}  // namespace gw::jobs
