#pragma once
// Inside the job manager (job_manager.hpp is its public face): the coordinator, which owns the
// manager's parts and does what a client asks of them, on one strand:
//
//   job_history         the history recorder: records and events into the store and onto the hub
//   job_states          the jobs that have not ended and every change of their state
//   submission_planner  what a submission must pass before the job exists, and its plan
//   lane_scheduler      which job runs on each controller, and when
//   job_recovery        what stopped, halted or crashed runs leave on a controller
//
// Its methods are defined by concern: job_coordinator.cpp (the registry's observer, start with
// restart recovery, shutdown), job_coordinator_submission.cpp, job_coordinator_control.cpp (cancel,
// pause, resume, next, leases). Only job_manager.cpp and those files include this.

#include <chrono>
#include <functional>
#include <memory>
#include <string>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/append.hpp>
#include <boost/asio/awaitable.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/strand.hpp>

#include "gateway/jobs/manager/job_manager_types.hpp"
#include "gateway/leases/lease_manager.hpp"

namespace spdlog {
class logger;
}

namespace gw {
class controller_registry;
class event_hub;
}  // namespace gw

namespace gw::devices {
class controller_observer;
}

namespace gw::jobs {

class job_history;
class job_holds;
class job_states;
class job_recovery;
class submission_planner;
class lane_scheduler;
class job_store;
struct live_job;

// How long shutdown waits for running jobs to stop after their HALT before closing the store anyway.
inline constexpr std::chrono::milliseconds shutdown_grace{5000};

// Shared with the coroutines it starts, so it outlives the job_manager object while they finish.
class job_coordinator final : public std::enable_shared_from_this<job_coordinator> {
  public:
    job_coordinator(boost::asio::any_io_executor executor, const boost::asio::any_io_executor& work_executor,
                    controller_registry& registry, std::shared_ptr<event_hub> hub,
                    std::shared_ptr<lease_manager> leases, job_manager_settings settings,
                    std::unique_ptr<job_store> store);
    ~job_coordinator();

    // Registers with the registry and the history recorder (after construction: needs weak_from_this).
    void attach();
    void start();
    void shutdown(std::function<void()> done);
    void abandon();

    void submit(submit_request r, job_handler<submit_result> h);
    void cancel(job_action a, job_handler<job_record> h);
    void pause(job_action a, job_handler<job_record> h);
    void resume(job_action a, job_handler<job_record> h);
    void next(job_action a, job_handler<job_record> h);
    void acquire_lease(std::string controller, std::string holder, std::chrono::seconds ttl,
                       job_handler<lease> h);

    // Which job holds each controller (any thread).
    const job_holds& holds() const;
    // The job history's reads (any thread; the async_ ones on its reader thread).
    const job_history& history() const { return *history_; }
    job_history& history() { return *history_; }

  private:
    template <typename T>
    void deliver(job_handler<T> h, operation_result<T> r) {
        boost::asio::post(executor_, boost::asio::append(std::move(h), std::move(r)));
    }
    bool stopping() const;

    // A job that has not ended, for an action: known in memory, or read back from the store (an
    // interrupted job of an earlier run of the gateway).
    operation_result<std::shared_ptr<live_job>> find_live(const std::string& id);
    operation_result<void> check_lease(const std::string& controller, const job_action& a) const;
    // The live job a control action names, once its caller may act on it (find_live, then check_lease).
    operation_result<std::shared_ptr<live_job>> find_for_action(const job_action& a);

    // On the strand, with the plan: stored and queued (or, for a dry run, answered).
    void submit_planned(submit_request r, job_handler<submit_result> h, operation_result<job_plan> plan);
    // Restart recovery: the jobs an earlier run of the gateway left active or queued.
    void recover_from_store();
    // Ends or leaves every job for the stop of the gateway (the running ones halted), then the store.
    boost::asio::awaitable<void> shutdown_coro(std::function<void()> done);

    boost::asio::any_io_executor executor_;                     // where completion handlers run
    boost::asio::strand<boost::asio::any_io_executor> strand_;  // everything else, store writes included
    controller_registry& registry_;
    std::shared_ptr<lease_manager> leases_;
    job_manager_settings settings_;
    std::shared_ptr<spdlog::logger> log_;

    std::shared_ptr<job_history> history_;
    std::shared_ptr<job_states> states_;
    std::shared_ptr<job_recovery> recovery_;
    std::shared_ptr<submission_planner> planner_;
    std::shared_ptr<lane_scheduler> scheduler_;
    std::shared_ptr<devices::controller_observer> observer_;

    bool started_ = false;  // strand only
};

}  // namespace gw::jobs
