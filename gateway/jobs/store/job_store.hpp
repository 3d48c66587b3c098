#pragma once
// Durable job history in SQLite (WAL journal, synchronous=FULL): the jobs,
// every state transition, every job event. Survives kill -9: each call is one transaction, committed
// before it returns. Blocking calls; the job_manager writes from its own strand, on its own thread.
//
// Two connections: writes go through one, reads through the other, each used by one call at a time.
// In WAL mode a read sees every committed write and never waits for a commit in progress (its fsync),
// so a reader on an I/O thread is not held up by the writer.
//
//   auto store = job_store::open("/var/lib/asi-gateway");   // creates <dir>/jobs.sqlite3
//   store->insert(record);
//   store->save(record);                                     // state, progress, reason, timestamps
//   store->append_event(id, json);                           // {"type":"step",...}
//
// Errors never throw: every call returns storage_unavailable (503) with SQLite's message (disk full,
// read-only file, locked) and leaves the database as it was (the transaction is rolled back).

#include <chrono>
#include <cstddef>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gateway/common/operation_error.hpp"
#include "gateway/jobs/job.hpp"
#include "gateway/jobs/job_query.hpp"

struct sqlite3;

namespace gw::jobs {

inline constexpr int job_store_schema_version = 2;
inline constexpr const char* job_store_file_name = "jobs.sqlite3";

struct job_store_options {
    // Bound on the database file (PRAGMA max_page_count); writes beyond it fail with "database or
    // disk is full" (storage_unavailable). Config storage.max_size_mb. 0 = SQLite's own limit.
    std::size_t max_size_mb = 1024;
    // How long a call waits for a lock held by another connection (another process on the file).
    std::chrono::milliseconds busy_timeout{5000};
};

class job_store {
  public:
    // Creates the directory and the database (schema versioned with PRAGMA user_version) if needed, and
    // migrates an older schema (version 1: no job_restore_commands table) in one transaction.
    // storage_unavailable when the directory cannot be created, the file is not a SQLite database,
    // or its schema version is newer than job_store_schema_version.
    static operation_result<std::unique_ptr<job_store>> open(const std::string& directory,
                                                             const job_store_options& options = {});
    ~job_store();
    job_store(const job_store&) = delete;
    job_store& operator=(const job_store&) = delete;

    // A new job; also records its first transition and, unless it is null, its first event (seq 1), all
    // in one transaction: a store that cannot take the job's history refuses the job itself.
    // invalid_state when the id or the idempotency key already exists (the manager calls
    // find_by_idempotency_key first, on its strand).
    operation_result<void> insert(const job_record& job, const nlohmann::json& first_event = nullptr);
    // Writes the job's mutable columns; appends a transition row when the state differs from the
    // stored one (from, to, reason, time); and, unless it is null, appends `event` (as append_event), all
    // in one transaction: a state or a step is never stored without its event, nor the event without it.
    operation_result<void> save(const job_record& job, const nlohmann::json& event = nullptr);
    // Stored as given, numbered per job (seq 1, 2, ...), with the time it was appended. unknown_job when
    // the job is not stored.
    operation_result<void> append_event(const std::string& job_id, const nlohmann::json& event);

    operation_result<std::optional<job_record>> find(const std::string& id) const;
    operation_result<std::optional<job_record>> find_by_idempotency_key(const std::string& key) const;
    // Newest first (descending id: ids are time-ordered), filtered; `before` pages (any string works
    // as a cursor). invalid_value (field "limit") when limit is outside 1..500.
    operation_result<job_page> list(const job_filter& filter) const;
    // The stored event objects, oldest first; at most `limit`. A state event's record is stored without
    // the fields that never change (id, controller, type, created, submitted_by, request_id,
    // idempotency_key) and read back with them from the job's row.
    operation_result<std::vector<nlohmann::json>> events(const std::string& job_id, std::size_t limit) const;
    // Transitions of a job, oldest first: {"from":..,"to":..,"reason":..,"at":"RFC 3339"}.
    operation_result<std::vector<nlohmann::json>> transitions(const std::string& job_id) const;
    // Jobs in any of these states (startup recovery), oldest first.
    operation_result<std::vector<job_record>> in_states(const std::vector<job_state>& states) const;

    // The commands that undo what the job's current run changed on its controller
    // (job_context::restore_if_stopped), in registration order, kept so that a gateway started after a
    // crash can send them. An empty list removes them. unknown_job when the job is not stored.
    operation_result<void> set_restore_commands(const std::string& job_id,
                                                const std::vector<std::string>& commands);
    // Empty when none are stored (or the job is unknown).
    operation_result<std::vector<std::string>> restore_commands(const std::string& job_id) const;
    // The jobs that have restore commands stored, the least recently updated first.
    operation_result<std::vector<std::string>> jobs_with_restore_commands() const;

    // Deletes up to `batch` ended jobs (succeeded, failed, cancelled) with their events, transitions and
    // restore commands, in one transaction: those that ended before `ended_before`, and those beyond
    // the newest `keep_newest` ended jobs. How many were deleted (fewer than `batch`: none are left).
    operation_result<std::size_t> delete_ended(std::optional<job_clock::time_point> ended_before,
                                               std::optional<std::size_t> keep_newest, std::size_t batch);

    // Checkpoints the WAL into the main file (clean shutdown).
    operation_result<void> flush();

    // How full the file is against storage.max_size_mb (limit_bytes 0: SQLite's own limit only); free
    // pages do not count, since they are used again before the file grows.
    struct fill_level {
        std::int64_t used_bytes = 0;
        std::int64_t limit_bytes = 0;
    };
    operation_result<fill_level> fill() const;

    // <directory>/jobs.sqlite3
    const std::string& path() const { return path_; }

  private:
    job_store(sqlite3* db, sqlite3* reader, std::string path);
    sqlite3* db_;      // writes (and the schema)
    sqlite3* reader_;  // reads (PRAGMA query_only)
    std::string path_;
    mutable std::mutex mutex_;       // one transaction at a time on db_
    mutable std::mutex read_mutex_;  // ... and on reader_
};

}  // namespace gw::jobs
