#pragma once
// The lane scheduler: which job runs on each controller, and when. Per controller one FIFO lane
// (job_lanes); the oldest queued job takes the controller once nothing holds it and its HALT latch is
// released, runs (job_execution, after what earlier runs owe the controller is put back), and hands
// the controller on when it ends: succeeded, failed (its settings put back first), cancelled, or paused
// keeping it (a HALT, a disconnect). A run whose spec records does so inside a recording of its own
// (run_recording). It hears of the controllers' events (a disconnect, a HALT latch,
// a TTL edge) from the registry's observer and passes them to the run there. Strand only, but
// counts_ttl_edges, which the controllers' strands call.
//
//   scheduler.queue(*job);                // at the back of its controller's lane
//   scheduler.dispatch(job->record.controller);  // starts it when the controller is free
//   scheduler.release("sim1", "j-1");     // j-1 no longer holds sim1: the next job may go

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/strand.hpp>

#include "devices/serial/controller_snapshot.hpp"
#include "gateway/jobs/manager/job_execution.hpp"
#include "gateway/jobs/manager/job_lanes.hpp"
#include "gateway/jobs/manager/ttl_edge_listeners.hpp"

namespace spdlog {
class logger;
}

namespace gw {
class controller_registry;
}

namespace gw::recordings {
class recorder;
}

namespace gw::jobs {

class job_states;
class job_recovery;
class submission_planner;

class lane_scheduler final : public std::enable_shared_from_this<lane_scheduler> {
  public:
    lane_scheduler(boost::asio::strand<boost::asio::any_io_executor> strand, controller_registry& registry,
                   std::shared_ptr<job_states> states, std::shared_ptr<job_recovery> recovery,
                   std::shared_ptr<submission_planner> planner,
                   std::shared_ptr<recordings::recorder> recorder, std::shared_ptr<spdlog::logger> log);

    // At the back of its controller's lane; `first`: at the front.
    void queue(live_job& job, bool first = false);
    // Out of its lane (a cancelled queued job).
    void unqueue(live_job& job);
    // The job that holds its controller gives it up and goes first in its lane (a resume of a job that
    // kept the controller while paused; a job halted while it was being started).
    void requeue_holder(live_job& job);
    bool holds_controller(const live_job& job) const;
    std::size_t queued(const std::string& controller) const { return lanes_.queued(controller); }
    // What a job queued on `controller` now waits for: the controller, when another job holds it or is
    // queued before it.
    std::optional<job_wait> queue_wait(const std::string& controller) const;
    // "j-1 running, j-2 queued": the jobs that hold the controller or wait for it; empty when none.
    std::string jobs_in_lane(const std::string& controller) const;
    // The jobs that hold a controller (running, paused, or being planned again).
    std::vector<std::shared_ptr<live_job>> holders() const;

    // Starts the controller's next job when it is free and not halted (and shows the halt waits).
    void dispatch(const std::string& controller);
    void dispatch_all();
    // `id` no longer holds the controller: the next job may go (dispatched later on the strand).
    void release(const std::string& controller, const std::string& id);

    // The controller's HALT latch is set (registry snapshot): no job may start there.
    bool halt_latched(const std::string& controller) const;
    // Connected and identified.
    bool controller_connected(const std::string& controller) const;

    // No job starts any more (shutdown).
    void close() { closed_ = true; }
    bool closed() const { return closed_; }
    // run() coroutines alive.
    std::size_t running() const { return running_; }

    // The registry's observer (any thread; posted to the strand).
    void controller_came_up(const std::string& controller);
    void controller_reconnected(const std::string& controller);
    void controller_snapshot_changed(const devices::controller_snapshot& s);
    // The controller's HALT latch was set (`by`) or released (nullopt): a run there stops (job_halted)
    // and nothing starts while it is set; once released the queue moves on.
    void controller_halt_latch_changed(const std::string& controller, std::optional<std::string> by);
    void controller_ttl_edge(const std::string& controller);
    // Whether a run on the controller counts its report frames as TTL edges (any thread).
    bool counts_ttl_edges(std::string_view controller) const { return ttl_listeners_.listening(controller); }

  private:
    // The job that holds the controller, when the manager knows it.
    std::shared_ptr<live_job> holder(const std::string& controller) const;
    // Shows `halt` as what the queued jobs there (and a job a HALT paused) wait for while the latch is
    // set, and takes it back once it is released.
    void show_halt_waits(const std::string& controller);
    // A recovered job has no plan: planned again (the submission planner) before it runs.
    void plan_again(const std::shared_ptr<live_job>& job, std::function<void(operation_result<void>)> done);
    void launch(const std::shared_ptr<live_job>& job);
    void run_finished(const std::shared_ptr<job_execution>& exec, const std::exception_ptr& e);
    bool stopped() const;

    boost::asio::strand<boost::asio::any_io_executor> strand_;
    controller_registry& registry_;
    std::shared_ptr<job_states> states_;
    std::shared_ptr<job_recovery> recovery_;
    std::shared_ptr<submission_planner> planner_;
    std::shared_ptr<recordings::recorder> recorder_;  // the runs that record (spec.record); null: none
    std::shared_ptr<spdlog::logger> log_;

    job_lanes lanes_;
    ttl_edge_listeners ttl_listeners_;  // thread-safe: the controllers' strands read it
    std::size_t running_ = 0;
    bool closed_ = false;
};

}  // namespace gw::jobs
