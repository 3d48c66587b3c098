#pragma once
// The job manager's recovery service: what a stopped, halted or crashed run leaves on a controller is
// made safe and put back. A stop sends HALT, switches the TTL output off and sends the job's restore
// commands (newest first); what does not reach the controller is owed to it (restore_ledger, kept in
// the job store) and sent once it is connected again, or before the next run there. After a restart,
// the jobs that were running when the gateway went down are owed a HALT first.
//
// Threads: the manager's strand, for everything but abandon().

#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/awaitable.hpp>
#include <boost/asio/strand.hpp>

#include "gateway/common/operation_error.hpp"
#include "gateway/controllers/operations.hpp"
#include "gateway/jobs/job.hpp"
#include "gateway/jobs/manager/job_execution.hpp"
#include "gateway/jobs/manager/restore_ledger.hpp"

namespace spdlog {
class logger;
}

namespace gw {
class controller_registry;
}

namespace gw::jobs {

class job_history;

class job_recovery final : public std::enable_shared_from_this<job_recovery> {
  public:
    job_recovery(boost::asio::strand<boost::asio::any_io_executor> strand, controller_registry& registry,
                 std::shared_ptr<job_history> history, std::shared_ptr<spdlog::logger> log);

    // ---- stopping a run ----

    // A run that stops for good (cancelled, or the gateway shutting down): HALT, TTL output low, the
    // restore commands; what is not delivered is owed (kept in the store only while shutting down).
    boost::asio::awaitable<void> safe_stop(std::shared_ptr<live_job> job);
    // A run a HALT stopped (paused): TTL output low if it may have left it high, the restore commands
    // (delivered or owed); the resumed run starts from the settings as they were before the job.
    boost::asio::awaitable<void> secure_after_halt(std::shared_ptr<live_job> job);
    // The job's restore commands, newest first; what does not reach the controller is owed.
    boost::asio::awaitable<void> restore_settings(std::shared_ptr<live_job> job);
    // Before a run starts: what earlier runs owe its controller, merged into the job's own list and
    // sent (a debt being sent meanwhile is waited for). Throws job_failure when it cannot be delivered.
    boost::asio::awaitable<void> put_back_before_run(std::shared_ptr<live_job> job);
    // A job paused by a disconnect while it had the TTL output high: "TTL Y=0" once it is back.
    void ttl_low_after_disconnect(const std::shared_ptr<live_job>& job);

    // ---- what is owed ----

    // Adds `rec` to what `controller` is owed (kept in the store under its job); `rec_is_older`: a debt
    // that could not be delivered, back after a newer one was added meanwhile.
    void owe(const std::string& controller, owed_restore rec, bool rec_is_older = false);
    // At start: the debts the store keeps of jobs that were not active (active ones come with start()).
    void recover_undelivered(const std::vector<job_record>& active);
    // Sends what each connected controller is owed (at start).
    void send_owed_to_connected();
    // Connected and identified (the first time or again): sends what it is owed.
    void controller_came_up(const std::string& controller);

    // The manager is shutting down: undelivered restore commands stay in the store for the next start.
    void begin_shutdown() { shutting_down_ = true; }
    // Nothing more is sent (any thread).
    void abandon() { abandoned_ = true; }

  private:
    void send(const std::string& controller);
    boost::asio::awaitable<std::pair<owed_restore, std::optional<operation_error>>> deliver(
        std::string controller, std::string request_id, owed_restore owed);
    // One restore command, as it was registered (the controller's answer, even a refusal, is a delivery).
    boost::asio::awaitable<operation_result<raw_command_result>> send_restore(std::string controller,
                                                                              std::string request_id,
                                                                              std::string command);
    // "TTL Y=0": empty when delivered, else why not.
    boost::asio::awaitable<std::string> ttl_output_low(std::string controller, std::string request_id);
    bool connected(const std::string& controller) const;

    boost::asio::strand<boost::asio::any_io_executor> strand_;
    controller_registry& registry_;
    std::shared_ptr<job_history> history_;
    std::shared_ptr<spdlog::logger> log_;
    restore_ledger restores_;
    bool shutting_down_ = false;
    std::atomic<bool> abandoned_{false};
};

}  // namespace gw::jobs
