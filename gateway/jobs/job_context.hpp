#pragma once
// What a running job may do: the interface between a job type's run() coroutine (array_job.cpp,
// scan_job.cpp, ...) and the job_manager that runs it (job_execution implements it).
//
// Every awaitable below throws job_cancelled once the job is cancelled (the manager has already sent
// HALT and "TTL Y=0"), job_halted once its controller was halted (no command of the run follows the
// HALT: each is guarded by the HALT count the run started with, devices::controller::
// async_guarded_command), and job_failure when the controller refuses, times out or disconnects. A run()
// that returns normally means the job succeeded. run() must call checkpoint() before each step:
// that is where pause takes effect ("stops after the current step") and where a paused job resumes.
//
// Threads: run() executes on the job's strand; all calls are made from there.

#include <chrono>
#include <cstddef>
#include <exception>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/awaitable.hpp>
#include <nlohmann/json.hpp>

#include "devices/ms2000/reply.hpp"
#include "devices/serial/controller_snapshot.hpp"
#include "gateway/common/operation_error.hpp"
#include "gateway/controllers/operations.hpp"
#include "gateway/jobs/job.hpp"
#include "gateway/jobs/job_plan.hpp"

namespace gw::jobs {

struct job_cancelled : std::exception {
    const char* what() const noexcept override { return "job cancelled"; }
};

// A HALT (any transport's emergency stop) stopped the run: the job pauses, keeps its controller and
// sends nothing more until someone resumes it.
struct job_halted : std::exception {
    explicit job_halted(std::string who) : by(std::move(who)) {}
    const char* what() const noexcept override { return "job halted"; }
    std::string by;
};

struct job_failure : std::exception {
    explicit job_failure(operation_error e) : error(std::move(e)) {}
    const char* what() const noexcept override { return error.message.c_str(); }
    operation_error error;
};

// How an array job (or a ring-buffer tour) moves on to its next position.
enum class advance_source : std::uint8_t {
    timer,  // after the dwell
    ttl,    // a rising edge on TTL IN0 (the controller's TTL events)
    next,   // a `next` call from REST/WebSocket (POST /api/v1/jobs/{id}/next)
};

class job_context {
  public:
    virtual ~job_context() = default;

    virtual const job_record& job() const = 0;  // spec, controller id, ...
    virtual const job_plan& plan() const = 0;
    // The first step to run: 0 for a fresh job, progress.steps_done for a resumed one.
    virtual std::size_t first_step() const = 0;
    // The controller's latest snapshot (positions, busy, TTL modes); never touches the serial line.
    virtual devices::controller_snapshot snapshot() const = 0;

    // Returns at once while running; waits while paused; throws job_cancelled when cancelled.
    virtual boost::asio::awaitable<void> checkpoint() = 0;
    // A pause was asked for: the next checkpoint() will wait. Lets a job make the stage safe first
    // (a gcode job switches its TTL output off before it waits).
    virtual bool pause_requested() const { return false; }

    // Progress. step_started sets current_step; step_done(i) marks steps 0..i done (steps_done =
    // i + 1), persists it and publishes a "step" event on jobs/<id> with `detail` merged in (for
    // an array: {"well":"C7","position":{"X":..,"Y":..}} - the measured position).
    virtual void step_started(std::size_t index) = 0;
    virtual void step_done(std::size_t index, nlohmann::json detail = {}) = 0;
    // Any other event on jobs/<id>: {"type": kind, ...detail}. Stored with the job's history.
    virtual void emit(std::string kind, nlohmann::json detail) = 0;
    // The stored "step" events of this job, oldest first (earlier runs included): a resumed run reads
    // what the steps before first_step() measured. Empty when the history cannot be read.
    virtual std::vector<nlohmann::json> completed_steps() const { return {}; }
    // Where uploaded G-code programs are (plan_context::gcode_files); empty: none.
    virtual std::filesystem::path gcode_files() const { return {}; }

    // A command that puts back a setting the job changed (for example "TTL X=0" after "TTL X=1").
    // run() restores its settings itself when it ends normally; when the run is cancelled or fails,
    // the manager sends these (after HALT and "TTL Y=0" for a cancel), newest first. A command that
    // is already registered is kept once. The list is stored with the job at once, so that a gateway
    // started after a crash sends it too (job_manager::start).
    virtual void restore_if_stopped(std::string command) = 0;
    // What settings of `verb` ("TTL" X: the IN0 mode; "SPEED" X Y) were before any job changed them,
    // by letter, for the commands that put them back: the value a restore command of the job names
    // (the oldest: registered before the change), else the controller's answer to "<verb> X? Y?" now.
    // Never the snapshot: after a restart it shows what a crashed run left. Earlier runs' leftovers
    // are put back before a run starts (job_recovery). job_failure on a reply without the values.
    virtual boost::asio::awaitable<std::map<char, double>> settings_before(std::string verb,
                                                                           std::string letters) = 0;

    // Serial work, tagged with the job's request id. command() sends a typed command as it is (no text
    // parsed back: job_commands builds them) and throws job_failure on ":N-<code>".
    virtual boost::asio::awaitable<devices::ms2000::reply> command(devices::ms2000::command c) = 0;
    virtual boost::asio::awaitable<move_result> move(move_request request) = 0;
    // Polls STATUS until the stage reports not busy ("N"); job_failure(timeout) after `timeout`.
    virtual boost::asio::awaitable<void> wait_idle(std::chrono::milliseconds timeout) = 0;

    // Cancellable waits.
    virtual boost::asio::awaitable<void> sleep(std::chrono::milliseconds duration) = 0;
    // A planned wait (a dwell, a delay between tours, G04): sleep(), shown as waiting_for "timer"
    // while it lasts when it is at least min_shown_timer. Polling uses sleep().
    virtual boost::asio::awaitable<void> dwell(std::chrono::milliseconds duration) = 0;
    // Waits for the next advance of `source` (timer: returns at once). TTL edges and `next` calls
    // that arrive while no one waits are counted and consumed by the following waits (none is lost).
    // Shown as waiting_for "ttl" / "next" while it waits.
    virtual boost::asio::awaitable<void> wait_advance(advance_source source) = 0;
    // What the run waits for, for a wait it does by other means (the controller follows TTL edges by
    // itself and the run polls until it arrives); empty when that wait is over. Shown as
    // progress.waiting_for; a change is published on jobs/<id>.
    virtual void set_waiting(std::optional<job_wait> what) = 0;
};

// settings_before("TTL", "X"): the IN0 mode to put back.
inline boost::asio::awaitable<int> in0_mode_before(job_context& ctx) {
    const auto before = co_await ctx.settings_before("TTL", "X");
    co_return static_cast<int>(before.at('X'));
}

}  // namespace gw::jobs
