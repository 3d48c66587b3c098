#include "gateway/jobs/job_manager_core.hpp"

namespace gw::jobs {

// ---------------------------------------------------------------------------------------------
// Persistence and publication (strand).

// A write the store refuses (disk full, read-only file) is never dropped: it waits in the job's
// queue in journal_, later writes of the job queue behind it (the history stays in order), and the queue is
// written again every store_retry_interval, before a resume (which is refused until it is stored) and at
// a clean shutdown. Meanwhile the record in memory is the truth, and get() answers from it.

void manager_core::save(const std::string& id, std::optional<job_record> record, const json& event,
                        bool progress) {
    const std::optional<job_record> saved = record;
    store_write(id, job_journal::write{std::move(record), event}, progress);
    if (!saved) return;
    // get() answers from memory for active jobs, and for ended ones until the store has their end. Set
    // after the write: what get() shows of a step is stored (unless the store refused it).
    std::lock_guard lock(records_mutex_);
    if (is_terminal(saved->state) && !journal_.has_pending(id))
        live_records_.erase(id);
    else
        live_records_[id] = *saved;
}

void manager_core::store_write(const std::string& id, job_journal::write w, bool progress) {
    if (auto stored = journal_.append(id, std::move(w)); !stored) store_refused(id, stored.error(), progress);
    note_store_fill();
}

void manager_core::note_store_fill(bool now) {
    const auto t = std::chrono::steady_clock::now();
    if (!now && t - store_fill_checked_ < settings_.store_fill_check) return;
    store_fill_checked_ = t;
    auto store = store_.get();
    auto fill =
        store ? store->fill()
              : operation_result<job_store::fill_level>(make_error(kind::storage_unavailable, "closed"));
    if (!fill || fill->limit_bytes <= 0) return;
    const double ratio = static_cast<double>(fill->used_bytes) / static_cast<double>(fill->limit_bytes);
    store_fill_.store(ratio);
    const bool high = ratio >= store_fill_warning;
    if (high && !store_fill_high_)
        log_->warn(
            "the job store is {:.0f} % full ({:.1f} of {:.1f} MiB): at 100 % submissions are refused and "
            "running jobs pause; raise storage.max_size_mb or move old history away",
            ratio * 100, static_cast<double>(fill->used_bytes) / 1048576.0,
            static_cast<double>(fill->limit_bytes) / 1048576.0);
    else if (!high && store_fill_high_)
        log_->info("the job store is {:.0f} % full again", ratio * 100);
    store_fill_high_ = high;
}

void manager_core::sweep_history(std::size_t deleted_so_far) {
    const auto& retention = settings_.retention;
    if (abandoned_ || shutting_down_ || retention.keeps_all_jobs()) return;
    auto store = store_.get();
    if (!store) return;
    std::optional<job_clock::time_point> ended_before;
    if (retention.max_age) ended_before = job_clock::now() - *retention.max_age;
    auto deleted = store->delete_ended(ended_before, retention.max_ended_jobs, retention_batch);
    if (!deleted) log_->warn("storage.retention: cannot delete ended jobs: {}", deleted.error().message);
    const std::size_t n = deleted ? *deleted : 0;
    if (n == retention_batch)  // more left: the next batch after what else waits on the strand
        return net::post(
            strand_, [self = shared_from_this(), total = deleted_so_far + n] { self->sweep_history(total); });
    if (deleted_so_far + n > 0) {
        log_->info("storage.retention: deleted {} ended job(s) with their history", deleted_so_far + n);
        note_store_fill(true);
    }
    retention_sweep_.expires_after(retention.sweep_interval);
    retention_sweep_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
        if (!ec) self->sweep_history();
    });
}

operation_result<void> manager_core::write_unstored(const std::string& id) {
    bool ended = false;
    auto stored = journal_.write_pending(id, &ended);
    // An ended job is read from the store from now on.
    if (stored && ended) {
        std::lock_guard lock(records_mutex_);
        live_records_.erase(id);
    }
    return stored;
}

void manager_core::store_refused(const std::string& id, const operation_error& e, bool progress) {
    if (journal_.refused(id, e.message))
        log_->error("job {}: the job store refused its history ({} write(s) kept, retried every {} ms): {}",
                    id, journal_.pending_count(id), store_retry_interval.count(), e.message);
    retry_unstored_later();
    if (!progress) return;
    // A step that cannot be recorded would be sent again by a resume after a restart: the run stops at
    // its next checkpoint (after the current step), as a client's pause does, and a resume continues once
    // the store takes the history again.
    auto it = jobs_.find(id);
    if (it == jobs_.end()) return;
    auto& job = *it->second;
    if (job.record.state != job_state::running || !job.exec || job.exec->cancelled()) return;
    if (job.storage_failure.empty())
        log_->warn("job {}: pausing after the current step: its history cannot be stored", id);
    job.storage_failure = e.message;
    job.exec->request_pause();
}

void manager_core::retry_unstored_later() {
    if (store_retry_armed_ || abandoned_) return;
    store_retry_armed_ = true;
    store_retry_.expires_after(store_retry_interval);
    store_retry_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
        self->store_retry_armed_ = false;
        if (ec || self->abandoned_) return;
        for (const auto& id : self->journal_.jobs_pending()) {
            if (auto stored = self->write_unstored(id); !stored) {
                self->journal_.refused(id, stored.error().message);
                continue;
            }
            // A job paused for its history waits for a client's resume now, which is possible again.
            auto job = self->jobs_.find(id);
            if (job != self->jobs_.end() && job->second->record.progress.waiting_for == job_wait::storage)
                self->set_waiting(*job->second, std::nullopt);
        }
        if (!self->journal_.empty()) self->retry_unstored_later();
    });
}

void manager_core::store_restore_commands(const std::string& id, const std::vector<std::string>& commands) {
    auto store = store_.get();
    if (!store) return;
    if (auto ok = store->set_restore_commands(id, commands); !ok)
        log_->error("job {}: cannot store its restore commands: {}", id, ok.error().message);
}

void manager_core::publish(const job_record& job, const json& event) {
    if (abandoned_ || !hub_) return;
    hub_->publish(job_topic(job.id), event);
    // Once the job has ended, its topic retires a while after its last event (a later event moves the
    // time): the hub would otherwise keep every job's replay buffer for ever.
    if (is_terminal(job.state)) hub_->retire_topic(job_topic(job.id), settings_.ended_job_topic_ttl);
}

void manager_core::set_state(live_job& job, job_state s, std::string reason,
                             std::optional<job_wait> waiting) {
    if (abandoned_) return;
    auto& r = job.record;
    const auto now = job_clock::now();
    r.state = s;
    r.reason = std::move(reason);
    r.updated = now;
    if (s == job_state::running && !r.started) r.started = now;
    if (is_terminal(s)) r.finished = now;
    if (s == job_state::succeeded) r.progress.remaining_s = 0.0;
    if (s == job_state::running || s == job_state::paused)
        holds_.hold(r.controller, job_hold{r.id, s, job.lease_id});
    else
        holds_.release(r.controller, r.id);
    r.progress.waiting_for = waiting;
    estimate_end(r, now);
    const auto event = state_event(r, now);
    save(r.id, r, event);
    publish(r, event);
    log_->info("job {} ({} on {}): {}{}{}", r.id, to_string(r.type), r.controller, to_string(s),
               r.reason.empty() ? "" : ": ", r.reason);
    if (is_terminal(s)) jobs_.erase(r.id);
}

void manager_core::set_waiting(live_job& job, std::optional<job_wait> what) {
    // A run reports its waits while running; once stopped, set_state has said what it waits for.
    if (job.record.state != job_state::running && what != std::nullopt) return;
    set_held_wait(job, what);
}

void manager_core::set_held_wait(live_job& job, std::optional<job_wait> what) {
    auto& r = job.record;
    auto& p = r.progress;
    if (abandoned_ || p.waiting_for == what) return;
    const auto now = job_clock::now();
    const bool was_unbounded = p.waiting_for && is_unbounded(*p.waiting_for);
    const bool unbounded = what && is_unbounded(*what);
    p.waiting_for = what;
    r.updated = now;
    // A timer is part of the step's estimate: the eta from the last step still holds.
    if (was_unbounded != unbounded) estimate_end(r, now);
    const auto event = state_event(r, now);
    save(r.id, r, event, false);
    publish(r, event);
}

std::optional<job_wait> manager_core::queue_wait(const std::string& controller) const {
    if (!lanes_.busy(controller)) return std::nullopt;
    return job_wait::controller;
}

// ---------------------------------------------------------------------------------------------
// Reads (any thread).

operation_result<job_record> manager_core::get(const std::string& id) const {
    {
        std::lock_guard lock(records_mutex_);
        if (auto it = live_records_.find(id); it != live_records_.end()) return it->second;
    }
    auto store = store_.get();
    if (!store) return make_error(kind::storage_unavailable, "the job store is closed");
    auto found = store->find(id);
    if (!found) return found.error();
    if (!*found) return make_error(kind::unknown_job, "no job with id \"" + id + "\"", "id");
    return std::move(**found);
}

operation_result<job_page> manager_core::list(const job_filter& f) const {
    auto store = store_.get();
    if (!store) return make_error(kind::storage_unavailable, "the job store is closed");
    auto page = store->list(f);
    if (!page) return page;
    // Active jobs as get() shows them: with what they wait for and their eta (which the store does not
    // keep), and their latest progress.
    std::lock_guard lock(records_mutex_);
    for (auto& j : page->jobs)
        if (auto it = live_records_.find(j.id); it != live_records_.end()) j = it->second;
    return page;
}

void manager_core::async_get(std::string id, job_manager::handler<job_record> h) {
    read_history<job_record>(std::move(h),
                             [id = std::move(id)](const manager_core& core) { return core.get(id); });
}

void manager_core::async_list(job_filter f, job_manager::handler<job_page> h) {
    read_history<job_page>(std::move(h),
                           [f = std::move(f)](const manager_core& core) { return core.list(f); });
}

void manager_core::async_events(std::string id, std::size_t limit,
                                job_manager::handler<std::vector<json>> h) {
    read_history<std::vector<json>>(std::move(h), [id = std::move(id), limit](const manager_core& core) {
        return core.events(id, limit);
    });
}

operation_result<std::vector<json>> manager_core::events(const std::string& id, std::size_t limit) const {
    auto store = store_.get();
    if (!store) return make_error(kind::storage_unavailable, "the job store is closed");
    auto found = store->find(id);
    if (!found) return found.error();
    if (!*found) return make_error(kind::unknown_job, "no job with id \"" + id + "\"", "id");
    return store->events(id, limit);
}

// ---------------------------------------------------------------------------------------------
// execution_host

void manager_core::on_step_started(live_job& job, std::size_t index) {
    if (!job.plan || index >= job.plan->steps.size()) return;
    job.record.progress.current_step = job.plan->steps[index].name;
    job.record.updated = job_clock::now();
    std::lock_guard lock(records_mutex_);
    live_records_[job.record.id] = job.record;
}

void manager_core::on_step_done(live_job& job, std::size_t index, json detail) {
    if (abandoned_ || !job.plan) return;
    auto& p = job.record.progress;
    const auto now = job_clock::now();
    const std::string name = index < job.plan->steps.size() ? job.plan->steps[index].name : "";
    p.steps_done = std::max(p.steps_done, std::min(index + 1, job.plan->steps.size()));
    p.current_step = name;
    p.remaining_s = remaining_from(*job.plan, index + 1);
    estimate_end(job.record, now);
    job.record.updated = now;
    const auto event = step_event(job.record, index, name, detail, now);
    save(job.record.id, job.record, event);
    publish(job.record, event);
}

void manager_core::on_emit(live_job& job, json event) {
    if (abandoned_) return;
    save(job.record.id, std::nullopt, event);
    publish(job.record, event);
}

std::vector<json> manager_core::step_events(const live_job& job) const {
    constexpr std::size_t all = 1'000'000;
    auto store = store_.get();
    if (!store) return {};
    auto stored = store->events(job.record.id, all);
    if (!stored) return {};
    // Then those the store has not taken yet, which follow them.
    for (auto& e : journal_.pending_events(job.record.id))
        stored->push_back(std::move(e));
    std::vector<json> out;
    for (auto& e : *stored)
        if (e.is_object() && e.value("type", "") == "step") out.push_back(std::move(e));
    return out;
}

void manager_core::on_restore_commands_changed(live_job& job) {
    if (abandoned_) return;
    store_restore_commands(job.record.id, job.restore_commands);
}

void manager_core::on_paused(live_job& job) {
    if (job.storage_failure.empty()) return set_state(job, job_state::paused, "paused");
    set_state(job, job_state::paused, "storage unavailable: " + job.storage_failure, job_wait::storage);
}

void manager_core::on_waiting(live_job& job, std::optional<job_wait> what) {
    set_waiting(job, what);
}

}  // namespace gw::jobs
