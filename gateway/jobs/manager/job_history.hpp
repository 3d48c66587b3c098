#pragma once
// The job manager's history recorder: every job's record and events go into the job store (through the
// journal, which keeps what the store refuses and writes it again every store_retry_interval), out on
// the event hub's jobs/<id> topic, and come back for GET /api/v1/jobs* on a reader thread of its own.
// It also watches the store's fill (the 80 % warning) and deletes old history (storage.retention).
//
// What a refusal means for a job (its run pauses after the current step) is the manager's to decide:
// the recorder tells its owner.
//
// Threads: the manager's strand for everything but the reads (get, list, events, remembered,
// fill_ratio, the async_ reads), which any thread may call.

#include <atomic>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <nlohmann/json.hpp>

#include "gateway/common/worker_thread.hpp"
#include "gateway/jobs/job.hpp"
#include "gateway/jobs/job_query.hpp"
#include "gateway/jobs/manager/job_manager_types.hpp"
#include "gateway/jobs/store/job_journal.hpp"
#include "gateway/jobs/store/job_store.hpp"
#include "gateway/jobs/store/job_store_handle.hpp"

namespace spdlog {
class logger;
}

namespace gw {
class event_hub;
}

namespace gw::jobs {

// How long a write the store refused waits before it is tried again.
inline constexpr std::chrono::milliseconds store_retry_interval{1000};
// The store's fill above which a warning is logged.
inline constexpr double store_fill_warning = 0.8;

class job_history final : public std::enable_shared_from_this<job_history> {
  public:
    // What the manager decides when the store refuses a job's history, or takes it again.
    struct owner {
        virtual ~owner() = default;
        // The store refused a write that records the job's progress (a step, a state).
        virtual void history_refused(const std::string& id, const std::string& why) = 0;
        // The store took every write of the job it had refused.
        virtual void history_stored_again(const std::string& id) = 0;
    };

    job_history(boost::asio::strand<boost::asio::any_io_executor> strand,
                boost::asio::any_io_executor executor, std::shared_ptr<event_hub> hub,
                job_manager_settings settings, std::shared_ptr<spdlog::logger> log,
                std::unique_ptr<job_store> store);

    void set_owner(std::weak_ptr<owner> o) { owner_ = std::move(o); }

    // ---- the strand ----

    // Once, at the manager's start: the store's fill, then the retention sweep.
    void start();
    // The job's record (null: unchanged) and its event, in one write, in order behind the job's earlier
    // writes. `progress`: a write a resume after a restart depends on (the owner hears of its refusal).
    void record(const std::string& id, std::optional<job_record> record, const nlohmann::json& event,
                bool progress = true);
    // The event on the hub's jobs/<id> topic; an ended job's topic retires a while after its last event.
    void publish(const job_record& job, const nlohmann::json& event);
    // What get() answers for a job the manager holds (active, or ended until the store has its end).
    void remember(const job_record& r);
    // The store's fill, read after writes at most every settings.store_fill_check (`now`: at once).
    void note_store_fill(bool now = false);
    void store_restore_commands(const std::string& id, const std::vector<std::string>& commands);
    // Writes the job's writes the store refused before; an ended job whose history is all stored is read
    // from the store after it (a resume waits for this).
    operation_result<void> write_unstored(const std::string& id);
    // The job's step events: those stored, then those the store has not taken yet.
    std::vector<nlohmann::json> step_events(const std::string& id) const;
    // The store, for what is not history: a submission's insert, the restart recovery's reads.
    const job_store_handle& store() const { return store_; }

    // The manager is shutting down: no more retention sweeps.
    void begin_shutdown() { shutting_down_ = true; }
    // A last try for what the store refused, then the store flushed and closed; nothing is written or
    // published afterwards.
    void stop();
    // Like a crash: the store closed as it is; nothing is written or published afterwards.
    void abandon();

    // ---- any thread ----

    operation_result<job_record> get(const std::string& id) const;
    // The record the manager holds for `id`, if any (not the store's).
    std::optional<job_record> remembered(const std::string& id) const;
    operation_result<job_page> list(const job_filter& f) const;
    operation_result<std::vector<nlohmann::json>> events(const std::string& id, std::size_t limit) const;
    // The reads above on the reader thread (bounded: 32 waiting, then queue_full); `h` on `executor`.
    void async_get(std::string id, job_handler<job_record> h);
    void async_list(job_filter f, job_handler<job_page> h);
    void async_events(std::string id, std::size_t limit, job_handler<std::vector<nlohmann::json>> h);
    std::optional<double> fill_ratio() const {
        const double r = store_fill_.load();
        return r < 0 ? std::nullopt : std::optional<double>(r);
    }

  private:
    template <typename T, typename Read>
    void read_on_reader(job_handler<T> h, Read read);

    void store_refused(const std::string& id, const operation_error& e, bool progress);
    void retry_unstored_later();
    void sweep(std::size_t deleted_so_far = 0);

    boost::asio::strand<boost::asio::any_io_executor> strand_;
    boost::asio::any_io_executor executor_;  // where read handlers without their own executor run
    std::shared_ptr<event_hub> hub_;
    job_manager_settings settings_;
    std::shared_ptr<spdlog::logger> log_;
    std::weak_ptr<owner> owner_;

    job_store_handle store_;
    job_journal journal_{store_, settings_.max_unstored_writes_per_job, log_};
    mutable std::mutex records_mutex_;
    std::map<std::string, job_record> remembered_;

    boost::asio::steady_timer retry_timer_{strand_};
    bool retry_armed_ = false;
    boost::asio::steady_timer sweep_timer_{strand_};
    std::atomic<bool> stopped_{false};
    bool shutting_down_ = false;
    std::atomic<double> store_fill_{-1};  // -1: not known (no limit, or not checked yet)
    bool store_fill_high_ = false;        // above store_fill_warning at the last check
    std::chrono::steady_clock::time_point store_fill_checked_{};

    worker_thread reader_{32};
};

}  // namespace gw::jobs
