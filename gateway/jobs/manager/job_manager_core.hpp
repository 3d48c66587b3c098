#pragma once
// Inside the job manager (gateway/jobs/job_manager.hpp is its public face): manager_core, the object
// that does the manager's work on one strand, and the helpers its parts share. Only the job_manager_*.cpp
// files include this. Its methods are defined by concern:
//
//   job_manager.cpp             the public job_manager, which forwards to the core; the registry observer
//   job_manager_history.cpp     states, events and their way into the store and onto the hub; reads;
//                               what a run reports (execution_host)
//   job_manager_lifecycle.cpp   start (restart recovery), shutdown, abandon
//   job_manager_submission.cpp  validate, plan, store and queue a submission
//   job_manager_runs.cpp        the lanes' dispatch, a run's start and end, safe stop, controller events
//   job_manager_control.cpp     cancel, pause, resume, next, leases
//   job_manager_recovery.cpp    what stopped or crashed runs owe a controller, and its delivery

#include <algorithm>
#include <array>
#include <atomic>
#include <fmt/format.h>
#include <map>
#include <mutex>

#include <boost/asio/append.hpp>
#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/redirect_error.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/asio/use_awaitable.hpp>
#include <spdlog/spdlog.h>

#include "devices/serial/controller_observer.hpp"
#include "gateway/common/job_id.hpp"
#include "gateway/config/logging.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/events/event_hub.hpp"
#include "gateway/jobs/job_json.hpp"
#include "gateway/jobs/kinds/job_kinds.hpp"
#include "gateway/jobs/kinds/safe_outputs.hpp"
#include "gateway/jobs/manager/job_execution.hpp"
#include "gateway/jobs/manager/job_history.hpp"
#include "gateway/jobs/manager/job_holds.hpp"
#include "gateway/jobs/manager/job_lanes.hpp"
#include "gateway/jobs/manager/job_manager.hpp"
#include "gateway/jobs/manager/job_recovery.hpp"
#include "gateway/jobs/manager/restore_ledger.hpp"
#include "gateway/jobs/manager/submission_planner.hpp"
#include "gateway/jobs/manager/ttl_edge_listeners.hpp"
#include "gateway/jobs/store/job_journal.hpp"
#include "gateway/jobs/store/job_store.hpp"
#include "gateway/jobs/store/job_store_handle.hpp"
#include "gateway/leases/lease_manager.hpp"
#include "gateway/storage/gcode_files.hpp"

namespace gw::jobs {

namespace net = boost::asio;
using json = nlohmann::json;
using kind = operation_error_kind;

// How long shutdown waits for running jobs to stop after their HALT before closing the store anyway.
inline constexpr std::chrono::milliseconds shutdown_grace{5000};

// progress.eta from remaining_s as of `now`: only a running job that waits for nothing unbounded has an
// end to expect.
inline void estimate_end(job_record& r, job_clock::time_point now) {
    auto& p = r.progress;
    const bool predictable =
        r.state == job_state::running && p.remaining_s && !(p.waiting_for && is_unbounded(*p.waiting_for));
    p.eta.reset();
    if (predictable)
        p.eta = now + std::chrono::duration_cast<job_clock::duration>(
                          std::chrono::duration<double>(std::max(0.0, *p.remaining_s)));
}

// Where uploaded G-code programs are (gateway/storage/gcode_files: the API's store uses the same).
inline std::filesystem::path gcode_files_directory(const job_manager_settings& s) {
    return gcode_directory(s.storage_path);
}

// Everything the manager does, on one strand. Shared with the run() coroutines and the registry
// observer, so it outlives the job_manager object while they finish.
class manager_core final : public execution_host,
                           public job_history::owner,
                           public std::enable_shared_from_this<manager_core> {
  public:
    manager_core(net::any_io_executor executor, const net::any_io_executor& work_executor,
                 controller_registry& registry, std::shared_ptr<event_hub> hub,
                 std::shared_ptr<lease_manager> leases, job_manager_settings settings,
                 std::unique_ptr<job_store> store)
        : executor_(std::move(executor)),
          strand_(net::make_strand(work_executor)),
          registry_(registry),
          hub_(std::move(hub)),
          leases_(std::move(leases)),
          settings_(std::move(settings)),
          log_(get_logger("jobs")),
          history_(
              std::make_shared<job_history>(strand_, executor_, hub_, settings_, log_, std::move(store))),
          recovery_(std::make_shared<job_recovery>(strand_, registry_, history_, log_)),
          planner_(std::make_shared<submission_planner>(strand_, registry_, leases_, history_, settings_)) {}

    void attach();
    void start();
    void shutdown(std::function<void()> done);
    void abandon();

    void submit(submit_request r, job_manager::handler<submit_result> h);
    void cancel(job_action a, job_manager::handler<job_record> h);
    void pause(job_action a, job_manager::handler<job_record> h);
    void resume(job_action a, job_manager::handler<job_record> h);
    void next(job_action a, job_manager::handler<job_record> h);
    void acquire_lease(std::string controller, std::string holder, std::chrono::seconds ttl,
                       job_manager::handler<lease> h);

    const job_holds& holds() const { return holds_; }
    // The job history's reads (job_history: any thread; the async_ ones on its reader thread).
    const job_history& history() const { return *history_; }
    job_history& history() { return *history_; }

    // Registry observer events (controller strands): posted here.
    void controller_snapshot_changed(const devices::controller_snapshot& s);
    // The controller is connected (and identified) again after it was not.
    void controller_reconnected(const std::string& controller);
    // Connected and identified (the first time or again): sends what start() left pending for it.
    void controller_came_up(const std::string& controller);
    void controller_ttl_edge(const std::string& controller);
    // The controller's HALT latch was set (`by`) or released (nullopt): a run there stops (job_halted)
    // and nothing starts while it is set; once released the queue moves on.
    void controller_halt_latch_changed(const std::string& controller, std::optional<std::string> by);
    // Whether a run on the controller counts its report frames as TTL edges (any thread).
    bool counts_ttl_edges(std::string_view controller) const { return ttl_listeners_.listening(controller); }
    std::optional<double> store_fill_ratio() const { return history_->fill_ratio(); }

    // execution_host
    void on_step_started(live_job& job, std::size_t index) override;
    void on_step_done(live_job& job, std::size_t index, json detail) override;
    void on_emit(live_job& job, json event) override;
    void on_paused(live_job& job) override;
    void on_waiting(live_job& job, std::optional<job_wait> what) override;
    std::vector<json> step_events(const live_job& job) const override;
    std::filesystem::path gcode_files() const override { return gcode_files_directory(settings_); }
    void on_restore_commands_changed(live_job& job) override;

    // job_history::owner
    void history_refused(const std::string& id, const std::string& why) override;
    void history_stored_again(const std::string& id) override;

  private:
    template <typename T>
    void deliver(job_manager::handler<T> h, operation_result<T> r) {
        net::post(executor_, net::append(std::move(h), std::move(r)));
    }

    operation_result<std::shared_ptr<live_job>> find_live(const std::string& id);
    operation_result<void> check_lease(const std::string& controller, const job_action& a) const;
    // The live job a control action names, once its caller may act on it (find_live, then check_lease).
    operation_result<std::shared_ptr<live_job>> find_for_action(const job_action& a);
    // "j-1 running, j-2 queued": the jobs that hold the controller or wait for it; empty when none.
    std::string jobs_in_lane(const std::string& controller) const;

    // On the strand, with the plan: stored and queued (or, for a dry run, answered).
    void submit_planned(submit_request r, job_manager::handler<submit_result> h,
                        operation_result<job_plan> plan);
    // A recovered job has no plan: planned again (the submission planner) before it runs.
    void plan_again(const std::shared_ptr<live_job>& job, std::function<void(operation_result<void>)> done);

    // Changes the state, persists it (transition) and publishes {"type":"state",...}. `waiting`: what
    // the job waits for in its new state (a run sets its own waits: on_waiting).
    void set_state(live_job& job, job_state s, std::string reason,
                   std::optional<job_wait> waiting = std::nullopt);
    // Changes progress.waiting_for (and eta: unknown from the start of an unbounded wait, estimated again
    // at its end) and publishes it as a state event; nothing when it is the same.
    void set_waiting(live_job& job, std::optional<job_wait> what);
    // The same for a job that is not running (queued, or paused holding its controller): the manager's
    // own say about what it waits for, the halt latch.
    void set_held_wait(live_job& job, std::optional<job_wait> what);
    // A job queued on `controller` now waits for it when another job holds it or is queued before it.
    std::optional<job_wait> queue_wait(const std::string& controller) const;
    void dispatch(const std::string& controller);
    // The controller's HALT latch is set (registry snapshot): no job may start there.
    bool halt_latched(const std::string& controller) const {
        auto s = registry_.get(controller);
        return s && s->halted;
    }
    // Shows `halt` as what the queued jobs there (and a job a HALT paused) wait for while the latch is
    // set, and takes it back once it is released.
    void show_halt_waits(const std::string& controller);
    void launch(const std::shared_ptr<live_job>& job);
    void run_finished(const std::shared_ptr<job_execution>& exec, const std::exception_ptr& e);
    void release(const std::string& controller, const std::string& id);
    net::awaitable<void> shutdown_coro(std::function<void()> done);

    bool controller_connected(const std::string& id) const {
        auto s = registry_.get(id);
        return s && s->state == devices::connection_state::connected && s->identity;
    }

    net::any_io_executor executor_;             // where completion handlers without their own executor run
    net::strand<net::any_io_executor> strand_;  // everything else, store writes included
    controller_registry& registry_;
    std::shared_ptr<event_hub> hub_;
    std::shared_ptr<lease_manager> leases_;
    job_manager_settings settings_;
    std::shared_ptr<spdlog::logger> log_;

    // The jobs' records and events: stored, published, read back.
    std::shared_ptr<job_history> history_;
    // What stopped, halted or crashed runs leave on a controller: made safe, owed, put back.
    std::shared_ptr<job_recovery> recovery_;
    // What a submission must pass before the job exists, and its plan.
    std::shared_ptr<submission_planner> planner_;

    // Strand only.
    std::map<std::string, std::shared_ptr<live_job>> jobs_;  // not terminal
    job_lanes lanes_;
    ttl_edge_listeners ttl_listeners_;  // thread-safe: the controllers' strands read it
    job_holds holds_;                   // thread-safe: api/ reads it for every operation
    std::size_t running_ = 0;           // run() coroutines alive
    bool started_ = false;
    bool shutting_down_ = false;
    std::atomic<bool> abandoned_{false};

    std::shared_ptr<devices::controller_observer> observer_;

    friend class job_manager;
};

}  // namespace gw::jobs
