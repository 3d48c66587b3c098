#pragma once
// The jobs that have not ended, and every change of their state: a state, what a job waits for, a
// step begun or done, an event. Each change is recorded (job_history) before it is published, and
// ends up in job_holds (which job holds a controller, read by api/). What a run reports
// (execution_host) and what the history recorder says of a job's writes (job_history::owner) arrive
// here. Strand only, but holds() and abandoned(), which any thread may read.
//
//   states.add(job);                                  // queued
//   states.set_state(*job, job_state::running, "");   // stored, then published on jobs/<id>
//   states.set_state(*job, job_state::succeeded, ""); // ended: states.find(id) is empty now

#include <atomic>
#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gateway/jobs/manager/job_execution.hpp"
#include "gateway/jobs/manager/job_history.hpp"
#include "gateway/jobs/manager/job_holds.hpp"
#include "gateway/jobs/manager/job_manager_types.hpp"

namespace spdlog {
class logger;
}

namespace gw::jobs {

// progress.eta from remaining_s as of `now`: only a running job that waits for nothing unbounded has an
// end to expect.
void estimate_end(job_record& r, job_clock::time_point now);

class job_states final : public execution_host,
                         public job_history::owner,
                         public std::enable_shared_from_this<job_states> {
  public:
    job_states(std::shared_ptr<job_history> history, job_manager_settings settings,
               std::shared_ptr<spdlog::logger> log);

    // A job that has not ended (submitted, or read back from the store): known here until it ends.
    void add(const std::shared_ptr<live_job>& job);
    std::shared_ptr<live_job> find(const std::string& id) const;
    const std::map<std::string, std::shared_ptr<live_job>>& all() const { return jobs_; }

    // Changes the state, persists it (transition) and publishes {"type":"state",...}. `waiting`: what
    // the job waits for in its new state (a run sets its own waits: on_waiting). An ended job is
    // forgotten here.
    void set_state(live_job& job, job_state s, std::string reason,
                   std::optional<job_wait> waiting = std::nullopt);
    // Changes progress.waiting_for (and eta: unknown from the start of an unbounded wait, estimated again
    // at its end) and publishes it as a state event; nothing when it is the same.
    void set_waiting(live_job& job, std::optional<job_wait> what);
    // The same for a job that is not running (queued, or paused holding its controller): the manager's
    // own say about what it waits for, the halt latch.
    void set_held_wait(live_job& job, std::optional<job_wait> what);

    // The run put back what it changed itself: nothing is left to restore (stored at once).
    void forget_restore_commands(const live_job& job);

    // Which job holds each controller (thread-safe: api/ reads it for every operation).
    const job_holds& holds() const { return holds_; }

    // Nothing is written or published any more (the gateway stops, or is torn down like a crash).
    void abandon() { abandoned_ = true; }
    bool abandoned() const { return abandoned_; }

    // execution_host
    void on_step_started(live_job& job, std::size_t index) override;
    void on_step_done(live_job& job, std::size_t index, nlohmann::json detail) override;
    void on_emit(live_job& job, nlohmann::json event) override;
    void on_paused(live_job& job) override;
    void on_waiting(live_job& job, std::optional<job_wait> what) override;
    std::vector<nlohmann::json> step_events(const live_job& job) const override;
    std::filesystem::path gcode_files() const override;
    void on_restore_commands_changed(live_job& job) override;

    // job_history::owner
    void history_refused(const std::string& id, const std::string& why) override;
    void history_stored_again(const std::string& id) override;

  private:
    std::shared_ptr<job_history> history_;
    job_manager_settings settings_;
    std::shared_ptr<spdlog::logger> log_;
    std::map<std::string, std::shared_ptr<live_job>> jobs_;  // not ended
    job_holds holds_;
    std::atomic<bool> abandoned_{false};
};

}  // namespace gw::jobs
