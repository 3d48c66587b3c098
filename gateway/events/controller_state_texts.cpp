#include "gateway/events/controller_state_texts.hpp"

#include <utility>

namespace gw {

void controller_state_texts::set(const std::string& id, std::shared_ptr<const std::string> text) {
    std::lock_guard lock(mutex_);
    texts_[id] = std::move(text);
}

std::shared_ptr<const std::string> controller_state_texts::get(const std::string& id) const {
    std::lock_guard lock(mutex_);
    auto it = texts_.find(id);
    return it == texts_.end() ? nullptr : it->second;
}

void controller_state_texts::forget(const std::string& id) {
    std::lock_guard lock(mutex_);
    texts_.erase(id);
}

}  // namespace gw
