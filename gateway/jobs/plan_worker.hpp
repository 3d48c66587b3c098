#pragma once
// The job planner's own thread. Planning can take long (a G-code program of megabytes is parsed,
// checked against the limits and timed), and the job manager's strand must not wait for it: every
// other job's steps, pauses and cancels go through that strand. A plan is computed here from copies
// (spec, snapshot, motion model) and its result posted back to the strand. Bounded: a planner with
// max_waiting plans queued or running refuses more (the caller answers queue_full).

#include <atomic>
#include <cstddef>
#include <utility>

#include <boost/asio/post.hpp>
#include <boost/asio/thread_pool.hpp>

namespace gw::jobs {

class plan_worker {
  public:
    static constexpr std::size_t max_waiting = 16;

    plan_worker() = default;
    ~plan_worker();  // waits for the plan being computed; those not started are dropped
    plan_worker(const plan_worker&) = delete;
    plan_worker& operator=(const plan_worker&) = delete;

    // Runs `work` on the planner's thread after the plans before it; false (and `work` dropped) when
    // max_waiting plans are waiting already. `work` must hand on, not drop, its reference to whatever
    // owns this worker (post its result on with the reference moved): the worker cannot be destroyed
    // on its own thread.
    template <typename Work>
    bool post(Work&& work) {
        if (waiting_.fetch_add(1) >= max_waiting) {
            waiting_.fetch_sub(1);
            return false;
        }
        boost::asio::post(pool_, [this, work = std::forward<Work>(work)]() mutable {
            waiting_.fetch_sub(1);
            std::move(work)();
        });
        return true;
    }

  private:
    boost::asio::thread_pool pool_{1};
    std::atomic<std::size_t> waiting_{0};
};

}  // namespace gw::jobs
