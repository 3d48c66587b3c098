#include "gateway/jobs/store/job_journal.hpp"

#include <algorithm>
#include <utility>

#include <spdlog/spdlog.h>

#include "gateway/jobs/store/job_store_handle.hpp"

namespace gw::jobs {

job_journal::job_journal(const job_store_handle& store, std::size_t max_writes_per_job,
                         std::shared_ptr<spdlog::logger> log)
    : store_(store), max_writes_per_job_(max_writes_per_job), log_(std::move(log)) {}

operation_result<void> job_journal::append(const std::string& id, write w) {
    auto& queued = pending_[id];
    queued.writes.push_back(std::move(w));
    if (queued.writes.size() > std::max<std::size_t>(max_writes_per_job_, 1)) {
        // A later record carries the job's state and progress, so what is lost is the oldest event.
        queued.writes.pop_front();
        if (queued.given_up++ == 0)
            log_->error(
                "job {}: more than {} writes of its history wait for the job store; the oldest are "
                "given up",
                id, max_writes_per_job_);
    }
    return write_pending(id);
}

operation_result<void> job_journal::write_pending(const std::string& id, bool* ended) {
    auto it = pending_.find(id);
    if (it == pending_.end()) return {};
    auto& writes = it->second.writes;
    std::optional<job_record> last_record;
    while (!writes.empty()) {
        const auto& w = writes.front();
        auto store = store_.get();
        if (!store) return make_error(operation_error_kind::storage_unavailable, "the job store is closed");
        auto ok = w.record ? store->save(*w.record, w.event) : store->append_event(id, w.event);
        if (!ok && ok.error().kind == operation_error_kind::storage_unavailable)
            return ok.error();  // kept: tried again
        // Any other error (the job is not stored at all) would come back every time.
        if (!ok) log_->error("job {}: cannot store its history: {}", id, describe(ok.error()));
        if (w.record) last_record = w.record;
        writes.pop_front();
    }
    if (it->second.given_up > 0)
        log_->error(
            "job {}: the job store takes its history again; {} write(s) of it were given up meanwhile", id,
            it->second.given_up);
    else if (!it->second.error.empty())
        log_->info("job {}: the job store takes its history again; it is stored up to date", id);
    pending_.erase(it);
    if (ended) *ended = last_record && is_terminal(last_record->state);
    return {};
}

bool job_journal::refused(const std::string& id, const std::string& message) {
    auto& queued = pending_[id];
    const bool first = queued.error.empty();
    queued.error = message;
    return first;
}

std::size_t job_journal::pending_count(const std::string& id) const {
    auto it = pending_.find(id);
    return it == pending_.end() ? 0 : it->second.writes.size();
}

std::vector<std::string> job_journal::jobs_pending() const {
    std::vector<std::string> ids;
    for (const auto& [id, queued] : pending_)
        ids.push_back(id);
    return ids;
}

std::vector<nlohmann::json> job_journal::pending_events(const std::string& id) const {
    std::vector<nlohmann::json> events;
    if (auto it = pending_.find(id); it != pending_.end())
        for (const auto& w : it->second.writes)
            if (!w.event.is_null()) events.push_back(w.event);
    return events;
}

}  // namespace gw::jobs
