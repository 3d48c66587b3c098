#pragma once
// What the job manager's callers and its parts share: its settings, a submission and its answer, a
// control action, and the completion handler of its asynchronous calls. Apart from job_manager.hpp
// so that the parts (job_history, job_states, the submission planner, the coordinator) need not
// include the public manager that is built on them.

#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <boost/asio/any_completion_handler.hpp>
#include <nlohmann/json.hpp>

#include "gateway/common/history_retention.hpp"
#include "gateway/common/operation_error.hpp"
#include "gateway/jobs/job.hpp"
#include "gateway/jobs/job_plan.hpp"

namespace gw::recordings {
class recorder;
}

namespace gw::jobs {

// How the manager answers: once, with a value or the operation's error.
template <typename T>
using job_handler = boost::asio::any_completion_handler<void(operation_result<T>)>;

struct job_manager_settings {
    std::string storage_path;                // directory; the database is <path>/jobs.sqlite3
    std::size_t storage_max_size_mb = 1024;  // job_store_options::max_size_mb (0: SQLite's own limit)
    bool restart_queued = false;             // after a restart, start the jobs that were queued
    std::size_t max_queued_per_controller = 1000;
    std::chrono::milliseconds idle_timeout{120000};  // one step's motion must end within this
    // Per job, the writes the store refused that wait in memory; beyond it the oldest is given up
    // (logged). A run that cannot pause between steps (autoplay, a firmware scan) could fill it.
    std::size_t max_unstored_writes_per_job = 10000;
    // An ended job's hub topic (jobs/<id>) is retired this long after its last event: the hub does not
    // keep every job's replay buffer for ever (its history is in the store).
    std::chrono::milliseconds ended_job_topic_ttl{600'000};
    // The job store's fill (store_fill_ratio, the 80 % warning) is read after writes at most this often.
    std::chrono::milliseconds store_fill_check{5000};
    // storage.retention: which ended jobs are deleted, at start and every sweep_interval.
    history_retention retention;
    // Called on the planner's thread as each plan starts (tests hold a plan there to show that the
    // manager goes on meanwhile); empty in the gateway.
    std::function<void(const std::string& controller)> on_plan_started;
    // Where the runs of jobs whose spec has "record": true record; null: such runs fail before they move.
    std::shared_ptr<recordings::recorder> recorder;
};

struct submit_request {
    std::string controller;
    job_type type = job_type::array;
    nlohmann::json spec;
    std::optional<std::string> idempotency_key;
    std::optional<std::string> lease_id;
    std::string principal = "anonymous";
    std::string request_id;
    bool dry_run = false;  // plan only: nothing stored, nothing sent
};

struct submit_result {
    job_record job;         // dry run: a record that was not stored (id empty, state queued)
    job_plan plan;          // the plan it runs (dry run: the plan it would run)
    bool replayed = false;  // Idempotency-Key seen before: `job` is the first submission's job
};

// Who asks for a control action (cancel/pause/resume/next), for lease checks.
struct job_action {
    std::string job_id;
    std::optional<std::string> lease_id;
    std::string principal = "anonymous";
    std::string request_id;
};

}  // namespace gw::jobs
