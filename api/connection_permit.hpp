#pragma once
// One slot of http.limits.max_connections. The listener hands a permit to each accepted connection;
// it moves from the HTTP session into the WebSocket session at an upgrade, so a connection counts
// toward the limit for as long as its socket lives, whatever protocol it speaks. Destroying the
// permit frees the slot (any thread).

#include <atomic>
#include <cstddef>
#include <memory>

namespace gw::api {

class connection_permit {
  public:
    using counter = std::atomic<std::size_t>;

    explicit connection_permit(std::shared_ptr<counter> count) : count_(std::move(count)) {
        count_->fetch_add(1);
    }
    ~connection_permit() { count_->fetch_sub(1); }

    connection_permit(const connection_permit&) = delete;
    connection_permit& operator=(const connection_permit&) = delete;

  private:
    std::shared_ptr<counter> count_;  // shared: the listener may be gone before the last session
};

}  // namespace gw::api
