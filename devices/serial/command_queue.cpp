#include "devices/serial/command_queue.hpp"

#include <utility>

namespace gw::devices {

std::vector<queued_command> command_queue::accept_halt() {
    halts_accepted_.fetch_add(1, std::memory_order_acq_rel);
    std::deque<queued_command> kept;
    std::vector<queued_command> dropped;
    for (auto& job : user_) {
        if (job.halts_seen)
            dropped.push_back(std::move(job));
        else
            kept.push_back(std::move(job));
    }
    user_ = std::move(kept);
    return dropped;
}

std::deque<queued_command>& command_queue::queue_of(const queued_command& job) {
    if (job.cmd.is_halt) return halts_;
    return job.internal ? internal_ : user_;
}

bool command_queue::push(queued_command& job) {
    auto& queue = queue_of(job);
    if (queue.size() >= limit_) return false;
    queue.push_back(std::move(job));
    return true;
}

void command_queue::push_front(queued_command job) {
    auto& queue = queue_of(job);
    queue.push_front(std::move(job));
}

std::optional<queued_command> command_queue::pop() {
    for (auto* queue : {&halts_, &internal_, &user_}) {
        if (!queue->empty()) {
            auto job = std::move(queue->front());
            queue->pop_front();
            return job;
        }
    }
    return std::nullopt;
}

std::vector<queued_command> command_queue::take_all() {
    std::vector<queued_command> jobs;
    for (auto* queue : {&halts_, &internal_, &user_}) {
        for (auto& job : *queue)
            jobs.push_back(std::move(job));
        queue->clear();
    }
    return jobs;
}

}  // namespace gw::devices
