#pragma once
// The controllers' lanes: per controller, the FIFO of queued job ids and the one job that holds the
// controller (running, paused, or planned again after a restart before it runs). Bookkeeping only: the
// job_manager decides what to queue, start and release, on its strand (not thread-safe).
//
//   lanes.enqueue("sim1", "j-1");
//   if (auto next = lanes.take_next("sim1", is_still_queued)) launch(*next);  // j-1 holds sim1 now
//   lanes.release("sim1", "j-1");                                             // the next may go

#include <cstddef>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace gw::jobs {

class job_lanes {
  public:
    // At the back of the controller's queue; `first`: at the front (a job that kept the controller
    // while paused goes before the others).
    void enqueue(const std::string& controller, const std::string& id, bool first = false);
    // Out of the queue (a cancelled queued job); nothing when it is not queued there.
    void remove(const std::string& controller, const std::string& id);

    // The oldest queued job for which `still_queued` holds takes the controller (the ones before it
    // that do not hold any more are dropped). Nothing when the controller is held or being planned
    // for, or when no queued job is left.
    std::optional<std::string> take_next(const std::string& controller,
                                         const std::function<bool(const std::string&)>& still_queued);
    // Ends the hold of `id`; nothing when another job holds the controller.
    void release(const std::string& controller, const std::string& id);

    // The job that holds the controller; empty when none.
    std::string holder(const std::string& controller) const;
    // The holder is being planned again (a job recovered after a restart) before it runs.
    void set_planning(const std::string& controller, bool planning);
    // A job queued now would wait: the controller is held, being planned for, or has jobs queued.
    bool busy(const std::string& controller) const;

    const std::deque<std::string>& queue(const std::string& controller) const;
    std::size_t queued(const std::string& controller) const { return queue(controller).size(); }
    // Every controller that has (or had) a lane.
    std::vector<std::string> controllers() const;

  private:
    struct lane {
        std::deque<std::string> queue;
        std::string holder;
        bool planning = false;
    };
    const lane* find(const std::string& controller) const;

    std::map<std::string, lane> lanes_;
};

}  // namespace gw::jobs
