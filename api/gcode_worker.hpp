#pragma once
// One thread for the G-code routes' blocking work (planning a program of millions of lines takes
// seconds; saving an upload writes tens of megabytes), so the I/O threads never wait for it. At most
// `max_pending` tasks wait or run; beyond that try_post() refuses (the route answers 503).
// Tasks must not own the worker (its destructor joins the thread). Thread-safe; owned by api_context.

#include <atomic>
#include <cstddef>
#include <memory>
#include <utility>

#include <boost/asio/post.hpp>
#include <boost/asio/thread_pool.hpp>

namespace gw::api {

class gcode_worker {
  public:
    explicit gcode_worker(std::size_t max_pending = 8) : max_pending_(max_pending) {}
    gcode_worker(const gcode_worker&) = delete;
    gcode_worker& operator=(const gcode_worker&) = delete;
    ~gcode_worker() { stop(); }

    template <typename Task>
    bool try_post(Task task) {
        if (pending_->fetch_add(1) >= max_pending_) {
            pending_->fetch_sub(1);
            return false;
        }
        boost::asio::post(pool_, [pending = pending_, task = std::move(task)]() mutable {
            task();
            pending->fetch_sub(1);
        });
        return true;
    }

    // Drops the tasks not started, waits for the running one (its answer still goes out).
    void stop() {
        pool_.stop();
        pool_.join();
    }

    std::size_t max_pending() const { return max_pending_; }

  private:
    std::size_t max_pending_;
    std::shared_ptr<std::atomic<std::size_t>> pending_ = std::make_shared<std::atomic<std::size_t>>(0);
    boost::asio::thread_pool pool_{1};
};

}  // namespace gw::api
