#pragma once
// Runs jobs: one running job per controller, a FIFO queue per controller, controllers in parallel.
// Validates and plans a submission before storing it, persists every transition and event in the
// job_store, publishes them on the event hub topic "jobs/<id>", honours leases and Idempotency-Key.
//
// Events on "jobs/<id>" (JSON objects with "type"):
//   {"type":"state","state":"running","reason":"","job":{...}} every transition (the whole job record
//                                                             under "job": see job_json.hpp)
//   {"type":"step","index":i,"name":"C7","steps_done":n,"steps_total":t,"percent":p,
//    "remaining_s":r, ...detail}                              every completed step
//   {"type":<kind>, ...}                                      job-specific (job_context::emit)
//
// Cancel: HALT at once, then "TTL Y=0" (outputs low), state cancelled. Pause: after the current
// step. A disconnect of the controller pauses a running job with reason "controller disconnected";
// resume continues from the last completed step once it is connected again. A job paused that way
// which had registered "TTL Y=0" (restore_if_stopped: a gcode job's laser) gets "TTL Y=0" as soon as
// the controller is connected again. A running job whose history the store refuses (disk full, read-only
// file) pauses after the current step, as for a client's pause, with reason "storage unavailable: <message>";
// its refused writes are kept in order and retried (every second, before a resume, at shutdown), and a resume
// is refused (storage_unavailable) until they are stored.
//
// Threads: public methods may be called from any thread. Completion handlers run on their associated
// executor (or the manager's), never inline. get/list/events read the store through its own connection:
// they never wait for a write in progress.

#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/any_completion_handler.hpp>
#include <boost/asio/any_io_executor.hpp>
#include <nlohmann/json.hpp>

#include "gateway/common/history_retention.hpp"
#include "gateway/common/operation_error.hpp"
#include "gateway/jobs/job.hpp"
#include "gateway/jobs/job_plan.hpp"
#include "gateway/jobs/job_query.hpp"
#include "gateway/jobs/manager/job_holds.hpp"
#include "gateway/jobs/manager/job_manager_types.hpp"
#include "gateway/leases/lease_manager.hpp"

namespace gw {
class controller_registry;
class event_hub;
class lease_manager;
}  // namespace gw

namespace gw::jobs {

class job_store;

class job_manager : public std::enable_shared_from_this<job_manager> {
  public:
    template <typename T>
    using handler = job_handler<T>;

    // Opens (creates) the store. Failure to open is returned, not thrown: main reports it and exits 1.
    // The manager works (and writes the store, which waits for the disk) on a strand of
    // `work_executor`; the gateway gives it a thread of its own, so that a slow disk never stalls the
    // I/O thread's HTTP, WebSocket, MQTT and serial work. Handlers without an executor of their own run
    // on `executor`.
    static operation_result<std::shared_ptr<job_manager>> create(
        boost::asio::any_io_executor executor, const boost::asio::any_io_executor& work_executor,
        controller_registry& registry, std::shared_ptr<event_hub> hub, std::shared_ptr<lease_manager> leases,
        job_manager_settings settings);
    // All on `executor` (tests).
    static operation_result<std::shared_ptr<job_manager>> create(boost::asio::any_io_executor executor,
                                                                 controller_registry& registry,
                                                                 std::shared_ptr<event_hub> hub,
                                                                 std::shared_ptr<lease_manager> leases,
                                                                 job_manager_settings settings);
    ~job_manager();

    // Marks jobs that were running or paused when the gateway stopped as interrupted (reason
    // "gateway restarted", their last completed step kept), and queues the queued ones again if
    // settings say so. Then starts dispatching. For each interrupted job, once its controller is
    // connected: "TTL Y=0" when it may have left the output high (safe_outputs.hpp), then the restore
    // commands its run had stored (job_context::restore_if_stopped), newest first, all under
    // safe_output_request_id(). The same for restore commands that could not be delivered before (a
    // cancel, failure or shutdown while the controller was unplugged): kept in the store and sent once
    // the controller is connected. A run waits for these (and for what its own earlier run left) to be
    // sent before it starts, and reads the settings it puts back from the controller afterwards: what
    // every recovery restores is what was there before any job changed it.
    void start();
    // Running jobs: HALT, TTL Y=0, state interrupted ("gateway shutting down"); then the store is
    // flushed and closed, then `done` runs on the manager's executor.
    void async_shutdown(std::function<void()> done);

    // Validates (spec, controller, lease, soft limits), plans, stores, queues. 201 semantics.
    void async_submit(submit_request request, handler<submit_result> h);

    operation_result<job_record> get(const std::string& id) const;
    // The job that holds `controller` (running or paused there) and its lease; any thread.
    std::optional<job_hold> holding(const std::string& controller) const;
    // How full the job store is against storage.max_size_mb (0..1), as last checked (after writes, at
    // most every few seconds); nullopt before the first check or without a size limit. Any thread.
    std::optional<double> store_fill_ratio() const;
    operation_result<job_page> list(const job_filter& filter) const;
    // The stored events of a job, oldest first (history survives restarts).
    operation_result<std::vector<nlohmann::json>> events(const std::string& id, std::size_t limit) const;
    // get, list and events for an I/O thread: the store is read on the job manager's history reader
    // thread (at most 32 reads waiting, then queue_full), the handler runs on its associated executor.
    void async_get(std::string id, handler<job_record> h);
    void async_list(job_filter filter, handler<job_page> h);
    void async_events(std::string id, std::size_t limit, handler<std::vector<nlohmann::json>> h);

    void async_cancel(job_action a, handler<job_record> h);  // queued/running/paused/interrupted
    void async_pause(job_action a, handler<job_record> h);   // running (takes effect after the step)
    void async_resume(job_action a, handler<job_record> h);  // paused / interrupted -> queued/running
    void async_next(job_action a, handler<job_record> h);    // a running job that advances on `next`
    // Takes an exclusive lease (lease_manager::acquire). Refused (busy) while a job holds the controller
    // or waits in its queue: those were submitted without the lease and must not run under it.
    void async_acquire_lease(std::string controller, std::string holder, std::chrono::seconds ttl,
                             handler<lease> h);

  private:
    job_manager(boost::asio::any_io_executor executor, const boost::asio::any_io_executor& work_executor,
                controller_registry& registry, std::shared_ptr<event_hub> hub,
                std::shared_ptr<lease_manager> leases, job_manager_settings settings,
                std::unique_ptr<job_store> store);

    struct impl;
    std::unique_ptr<impl> impl_;
};

}  // namespace gw::jobs

namespace gw {
struct gateway_config;
}
namespace gw::jobs {
// The manager's settings from the config file: storage.path, storage.max_size_mb, jobs.*
// (job_manager_settings.cpp).
job_manager_settings make_job_manager_settings(const gateway_config& config);
}  // namespace gw::jobs
