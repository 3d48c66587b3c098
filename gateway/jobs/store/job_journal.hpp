#pragma once
// The way of a job's history into the job_store: every write of a job (its record, one of its events)
// goes through the job's queue, so that the writes reach the store in order. A write the store refuses
// (disk full, read-only file) stays queued with those behind it until write_pending() stores them; the
// job_manager decides when to try again and what a refusal means for the job. Memory is bounded: beyond
// max_writes_per_job queued writes, the oldest is given up (logged).
//
// Threads: the job_manager's strand only. The store is shared with the manager's readers through the
// handle.

#include <cstddef>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gateway/common/operation_error.hpp"
#include "gateway/jobs/job.hpp"

namespace spdlog {
class logger;
}

namespace gw::jobs {

class job_store_handle;

class job_journal {
  public:
    // The job record (state, progress) and/or one of its events (null: none), stored in one transaction.
    struct write {
        std::optional<job_record> record;
        nlohmann::json event;
    };

    // `store` may be reset (closed) by its owner; writes are then refused as storage_unavailable.
    job_journal(const job_store_handle& store, std::size_t max_writes_per_job,
                std::shared_ptr<spdlog::logger> log);

    // Queues `w` behind the job's unstored writes, then writes them (write_pending).
    operation_result<void> append(const std::string& id, write w);
    // Writes the job's queued writes, oldest first, until the store refuses one: its error (the rest stay
    // queued). When all are stored the job is forgotten, and `ended` says whether the last record
    // written was a terminal state.
    operation_result<void> write_pending(const std::string& id, bool* ended = nullptr);
    // Notes the store's refusal; true for the first since the job's writes were last all stored.
    bool refused(const std::string& id, const std::string& message);

    bool has_pending(const std::string& id) const { return pending_.contains(id); }
    bool empty() const { return pending_.empty(); }
    std::size_t pending_count(const std::string& id) const;
    std::vector<std::string> jobs_pending() const;
    // The events of the job's queued writes, oldest first (they follow those in the store).
    std::vector<nlohmann::json> pending_events(const std::string& id) const;

  private:
    struct pending_writes {
        std::deque<write> writes;
        std::string error;  // the store's last refusal
        std::size_t given_up = 0;
    };

    const job_store_handle& store_;
    std::size_t max_writes_per_job_;
    std::shared_ptr<spdlog::logger> log_;
    std::map<std::string, pending_writes> pending_;
};

}  // namespace gw::jobs
