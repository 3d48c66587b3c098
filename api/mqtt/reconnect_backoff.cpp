#include "api/mqtt/reconnect_backoff.hpp"

#include <algorithm>

namespace gw::api {

reconnect_backoff::reconnect_backoff(std::chrono::milliseconds min, std::chrono::milliseconds max,
                                     std::uint64_t seed)
    : min_(std::max(min, std::chrono::milliseconds(1))),
      max_(std::max(max, min_)),
      base_(min_),
      random_(seed) {}

std::chrono::milliseconds reconnect_backoff::next() {
    const auto base = base_;
    base_ = std::min(base_ * 2, max_);
    std::uniform_int_distribution<std::chrono::milliseconds::rep> pick(base.count() - base.count() / 2,
                                                                       base.count());
    return std::chrono::milliseconds(pick(random_));
}

void reconnect_backoff::reset() {
    base_ = min_;
}

}  // namespace gw::api
