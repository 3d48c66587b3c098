#pragma once
// storage.retention: how much ended history the gateway keeps. Ended jobs (succeeded, failed,
// cancelled; never queued, running, paused or interrupted ones, which may still be resumed) with
// their events and transitions, and audit entries, are deleted when older than max_age or beyond
// the newest max_ended_jobs / max_audit_entries. Nothing is deleted by default. The job store and the
// audit trail sweep on their own threads, at start and every sweep_interval, in small transactions.

#include <chrono>
#include <cstddef>
#include <optional>

namespace gw {

struct history_retention {
    std::optional<std::chrono::hours> max_age;     // storage.retention.max_age_days
    std::optional<std::size_t> max_ended_jobs;     // the newest ended jobs kept
    std::optional<std::size_t> max_audit_entries;  // the newest audit entries kept
    std::chrono::seconds sweep_interval{3600};

    bool keeps_all_jobs() const { return !max_age && !max_ended_jobs; }
    bool keeps_all_audit() const { return !max_age && !max_audit_entries; }
};

// Rows deleted per transaction: a sweep never holds the store for long.
inline constexpr std::size_t retention_batch = 200;

}  // namespace gw
