#pragma once
// A thread of its own for work that must not hold up a strand or an I/O thread: the job manager's
// planner (a G-code program of megabytes is parsed, checked against the limits and timed) and the
// reads of the job history from SQLite; the recorder's writes of frames. Work runs from copies and
// posts its result on. Bounded: with
// max_waiting pieces of work waiting to start, post() refuses more (the caller answers queue_full).

#include <atomic>
#include <cstddef>
#include <utility>

#include <boost/asio/post.hpp>
#include <boost/asio/thread_pool.hpp>

namespace gw {

class worker_thread {
  public:
    explicit worker_thread(std::size_t max_waiting) : max_waiting_(max_waiting) {}
    ~worker_thread();  // waits for the work running now; work not started is dropped
    worker_thread(const worker_thread&) = delete;
    worker_thread& operator=(const worker_thread&) = delete;

    // Runs `work` on the thread after the work before it; false (and `work` dropped) when max_waiting
    // pieces are waiting already. `work` must hand on, not drop, its reference to whatever owns this
    // worker (post its result on with the reference moved): the worker cannot be destroyed on its own
    // thread.
    template <typename Work>
    bool post(Work&& work) {
        if (waiting_.fetch_add(1) >= max_waiting_) {
            waiting_.fetch_sub(1);
            return false;
        }
        boost::asio::post(pool_, [this, work = std::forward<Work>(work)]() mutable {
            waiting_.fetch_sub(1);
            std::move(work)();
        });
        return true;
    }

    std::size_t max_waiting() const { return max_waiting_; }

  private:
    const std::size_t max_waiting_;
    boost::asio::thread_pool pool_{1};
    std::atomic<std::size_t> waiting_{0};
};

}  // namespace gw
