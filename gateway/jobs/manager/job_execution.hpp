#pragma once
// One run of a job: the job_context a job type's run() coroutine uses, implemented on the manager's
// strand over the controller_registry. The job_manager creates one per run (a fresh run, or a resume
// whose coroutine had ended) and talks to it only from its strand.
//
// Waiting: one steady_timer serves every wait (sleep, advance, pause) - a job coroutine awaits one
// thing at a time. wake() cancels it; the waiter re-checks its condition. Every awaitable checks the
// stop flags before and after it suspends: after cancel() (or fail()) no new serial command starts and
// the next await throws job_cancelled (job_failure).
//
// TTL edges: one per TTL_REPORT frame of the controller (report_event: the firmware latches the
// encoders on every IN0 edge). `next` calls and edges that arrive while nothing waits are counted and
// consumed by later wait_advance() calls, one each.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>

#include "gateway/jobs/job_context.hpp"

namespace gw {
class controller_registry;
}

namespace gw::jobs {

class job_execution;

// A job the manager knows in memory (queued, running, paused, or recovered after a restart).
struct live_job {
    job_record record;
    std::optional<job_plan> plan;         // empty until planned (recovered jobs are planned again)
    std::shared_ptr<job_execution> exec;  // while a run() coroutine exists
    bool queued_in_lane = false;          // in its controller's FIFO
    // The lease it was submitted (or last resumed) under: its holder may still operate the controller
    // while the job holds it (job_holds).
    std::optional<std::string> lease_id;
    bool stopping = false;  // a cancel is sending HALT / TTL Y=0: the job keeps the controller
    // job_context::restore_if_stopped, registration order. What a run left changed (a disconnect
    // ended it) stays here: the next run puts it back before it starts.
    std::vector<std::string> restore_commands;
    // Paused by a disconnect while it had registered "TTL Y=0": sent when the controller is back.
    bool ttl_low_on_reconnect = false;
    // The store refused this job's history while it ran (SQLite's message): it pauses at the next
    // checkpoint with the reason "storage unavailable: <message>".
    std::string storage_failure;
};

// What an execution reports to the manager (which persists and publishes). Called on the strand.
class execution_host {
  public:
    virtual ~execution_host() = default;
    virtual void on_step_started(live_job& job, std::size_t index) = 0;
    virtual void on_step_done(live_job& job, std::size_t index, nlohmann::json detail) = 0;
    virtual void on_emit(live_job& job, nlohmann::json event) = 0;
    // checkpoint() honoured a pause request: the job is paused now.
    virtual void on_paused(live_job& job) = 0;
    // The run started or stopped waiting (job_context::set_waiting, wait_advance, dwell).
    virtual void on_waiting(live_job& job, std::optional<job_wait> what) = 0;
    // The job's stored "step" events, oldest first.
    virtual std::vector<nlohmann::json> step_events(const live_job& job) const = 0;
    // plan_context::gcode_files.
    virtual std::filesystem::path gcode_files() const { return {}; }
    // The run registered another restore command (job.restore_commands): the manager persists the list.
    virtual void on_restore_commands_changed(live_job& /*job*/) {}
};

class job_execution final : public job_context, public std::enable_shared_from_this<job_execution> {
  public:
    using strand_type = boost::asio::strand<boost::asio::any_io_executor>;

    // `halts_seen`: the controller's HALT count read before the manager found it not halted; every
    // command of the run is refused after a later HALT.
    job_execution(strand_type strand, controller_registry& registry, std::weak_ptr<execution_host> host,
                  std::shared_ptr<live_job> job, std::size_t first_step, std::uint64_t halts_seen);

    // job_context
    const job_record& job() const override { return job_->record; }
    const job_plan& plan() const override { return *job_->plan; }
    std::size_t first_step() const override { return first_step_; }
    devices::controller_snapshot snapshot() const override;
    boost::asio::awaitable<void> checkpoint() override;
    void step_started(std::size_t index) override;
    void step_done(std::size_t index, nlohmann::json detail = {}) override;
    void emit(std::string kind, nlohmann::json detail) override;
    std::vector<nlohmann::json> completed_steps() const override;
    std::filesystem::path gcode_files() const override;
    void restore_if_stopped(std::string command) override;
    boost::asio::awaitable<std::map<char, double>> settings_before(std::string verb,
                                                                   std::string letters) override;
    boost::asio::awaitable<devices::ms2000::reply> command(devices::ms2000::command c) override;
    boost::asio::awaitable<move_result> move(move_request request) override;
    boost::asio::awaitable<void> wait_idle(std::chrono::milliseconds timeout) override;
    boost::asio::awaitable<void> sleep(std::chrono::milliseconds duration) override;
    boost::asio::awaitable<void> dwell(std::chrono::milliseconds duration) override;
    boost::asio::awaitable<void> wait_advance(advance_source source) override;
    void set_waiting(std::optional<job_wait> what) override;

    // From the manager (strand).
    void cancel();                     // every await from now on throws job_cancelled
    void fail(operation_error error);  // ... throws job_failure (a disconnect); the first one wins
    void halt(std::string by);         // ... throws job_halted: the controller was halted
    void request_pause();              // the next checkpoint() pauses
    void resume();                     // a paused checkpoint() returns
    void ttl_edge();
    void next();
    // The hub of the host is gone (the manager was destroyed): stop quietly.
    void abandon();
    // The HALT count the run's commands are checked against from now on: read again once what an
    // earlier run owed the controller was put back (its HALT comes before this run, not during it).
    void rebase_halts(std::uint64_t halts_seen) { halts_seen_ = halts_seen; }

    bool cancelled() const { return cancelled_; }
    bool abandoned() const { return abandoned_; }
    const std::optional<operation_error>& failure() const { return failure_; }
    const std::optional<std::string>& halted_by() const { return halted_by_; }
    bool pause_requested() const override { return pause_requested_; }
    bool waiting_paused() const { return waiting_paused_; }
    const std::shared_ptr<live_job>& live() const { return job_; }
    const std::string& request_id() const { return request_id_; }

  private:
    void throw_if_stopped() const;
    void wake();
    boost::asio::awaitable<void> wait_until(std::chrono::steady_clock::time_point deadline);

    strand_type strand_;
    controller_registry& registry_;
    std::weak_ptr<execution_host> host_;
    std::shared_ptr<live_job> job_;
    std::size_t first_step_ = 0;
    std::uint64_t halts_seen_ = 0;
    std::string request_id_;  // "job-<id>" on every serial command
    boost::asio::steady_timer signal_;

    bool cancelled_ = false;
    bool abandoned_ = false;
    std::optional<operation_error> failure_;
    std::optional<std::string> halted_by_;
    bool pause_requested_ = false;
    bool waiting_paused_ = false;
    std::uint64_t ttl_pending_ = 0;
    std::uint64_t next_pending_ = 0;
};

}  // namespace gw::jobs
