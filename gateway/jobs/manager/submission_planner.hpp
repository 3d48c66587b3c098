#pragma once
// The job manager's submission planner: what a submission must pass before the job exists (its
// controller, the caller's lease, an Idempotency-Key already stored), and the plan, computed on a
// planner thread of its own from the controller's snapshot (the motion settings included: no serial
// round trip). The manager then queues and stores the job.
//
// Threads: the manager's strand; plans run on the planner thread (bounded: max_waiting plans, then
// queue_full) and come back on the strand.

#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/strand.hpp>
#include <nlohmann/json.hpp>

#include "gateway/common/worker_thread.hpp"
#include "gateway/jobs/job.hpp"
#include "gateway/jobs/job_plan.hpp"
#include "gateway/jobs/manager/job_manager_types.hpp"

namespace gw {
class controller_registry;
class lease_manager;
}  // namespace gw

namespace gw::jobs {

class job_history;

class submission_planner final : public std::enable_shared_from_this<submission_planner> {
  public:
    submission_planner(boost::asio::strand<boost::asio::any_io_executor> strand,
                       controller_registry& registry, std::shared_ptr<lease_manager> leases,
                       std::shared_ptr<job_history> history, const job_manager_settings& settings);

    // Before the plan: the controller, the caller's lease, a stored job with the same Idempotency-Key
    // (the same request: answered as a replay; another one: refused). The answer when the submission
    // ends here; nullopt to go on.
    std::optional<operation_result<submit_result>> admit(const submit_request& r) const;
    // After the plan, right before the job is stored: the lease again (one may have been taken while
    // the job planned) and the key again (another submission with it may have been stored meanwhile).
    std::optional<operation_result<submit_result>> admit_again(const submit_request& r) const;

    // Plans `type` with `spec` for the controller as its snapshot is now, on the planner thread; `done`
    // runs on the strand with the plan, or not_connected, invalid_value (not an object) or queue_full.
    using plan_handler = std::function<void(operation_result<job_plan>)>;
    void plan(const std::string& controller, job_type type, nlohmann::json spec, plan_handler done);

    // The queued job a plan makes of the request (its id not yet given).
    static job_record record_of(const submit_request& r, const job_plan& plan, job_clock::time_point now);

  private:
    std::optional<operation_result<submit_result>> stored_with_key(const submit_request& r) const;
    motion_model motion_model_for(const devices::controller_snapshot& snapshot) const;

    boost::asio::strand<boost::asio::any_io_executor> strand_;
    controller_registry& registry_;
    std::shared_ptr<lease_manager> leases_;
    std::shared_ptr<job_history> history_;
    std::filesystem::path gcode_files_;
    std::function<void(const std::string&)> on_plan_started_;

    // Last: destroyed first, it waits for a plan being computed while the rest still exists.
    worker_thread planner_{16};
};

}  // namespace gw::jobs
