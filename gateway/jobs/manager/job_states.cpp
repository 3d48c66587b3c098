#include "gateway/jobs/manager/job_states.hpp"

#include <algorithm>

#include <spdlog/spdlog.h>

#include "gateway/jobs/job_json.hpp"
#include "gateway/jobs/job_plan.hpp"
#include "gateway/storage/gcode_files.hpp"

namespace gw::jobs {

using json = nlohmann::json;

void estimate_end(job_record& r, job_clock::time_point now) {
    auto& p = r.progress;
    const bool predictable =
        r.state == job_state::running && p.remaining_s && !(p.waiting_for && is_unbounded(*p.waiting_for));
    p.eta.reset();
    if (predictable)
        p.eta = now + std::chrono::duration_cast<job_clock::duration>(
                          std::chrono::duration<double>(std::max(0.0, *p.remaining_s)));
}

job_states::job_states(std::shared_ptr<job_history> history, job_manager_settings settings,
                       std::shared_ptr<spdlog::logger> log)
    : history_(std::move(history)), settings_(std::move(settings)), log_(std::move(log)) {}

void job_states::add(const std::shared_ptr<live_job>& job) {
    jobs_[job->record.id] = job;
}

std::shared_ptr<live_job> job_states::find(const std::string& id) const {
    auto it = jobs_.find(id);
    return it == jobs_.end() ? nullptr : it->second;
}

void job_states::forget_restore_commands(const live_job& job) {
    history_->store_restore_commands(job.record.id, {});
}

std::filesystem::path job_states::gcode_files() const {
    return gcode_directory(settings_.storage_path);
}

// ---------------------------------------------------------------------------------------------
// A job's state and what it waits for, each change recorded (job_history) before it is published.

void job_states::set_state(live_job& job, job_state s, std::string reason, std::optional<job_wait> waiting) {
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
    history_->record(r.id, r, event);
    history_->publish(r, event);
    log_->info("job {} ({} on {}): {}{}{}", r.id, to_string(r.type), r.controller, to_string(s),
               r.reason.empty() ? "" : ": ", r.reason);
    if (is_terminal(s)) jobs_.erase(r.id);
}

void job_states::set_waiting(live_job& job, std::optional<job_wait> what) {
    // A run reports its waits while running; once stopped, set_state has said what it waits for.
    if (job.record.state != job_state::running && what != std::nullopt) return;
    set_held_wait(job, what);
}

void job_states::set_held_wait(live_job& job, std::optional<job_wait> what) {
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
    history_->record(r.id, r, event, false);
    history_->publish(r, event);
}

// ---------------------------------------------------------------------------------------------
// execution_host

void job_states::on_step_started(live_job& job, std::size_t index) {
    if (!job.plan || index >= job.plan->steps.size()) return;
    job.record.progress.current_step = job.plan->steps[index].name;
    job.record.updated = job_clock::now();
    history_->remember(job.record);
}

void job_states::on_step_done(live_job& job, std::size_t index, json detail) {
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
    history_->record(job.record.id, job.record, event);
    history_->publish(job.record, event);
}

void job_states::on_emit(live_job& job, json event) {
    if (abandoned_) return;
    history_->record(job.record.id, std::nullopt, event);
    history_->publish(job.record, event);
}

std::vector<json> job_states::step_events(const live_job& job) const {
    return history_->step_events(job.record.id);
}

void job_states::on_restore_commands_changed(live_job& job) {
    if (abandoned_) return;
    history_->store_restore_commands(job.record.id, job.restore_commands);
}

void job_states::on_paused(live_job& job) {
    if (job.storage_failure.empty()) return set_state(job, job_state::paused, "paused");
    set_state(job, job_state::paused, "storage unavailable: " + job.storage_failure, job_wait::storage);
}

void job_states::on_waiting(live_job& job, std::optional<job_wait> what) {
    set_waiting(job, what);
}

// ---------------------------------------------------------------------------------------------
// job_history::owner

void job_states::history_refused(const std::string& id, const std::string& why) {
    // A step that cannot be recorded would be sent again by a resume after a restart: the run stops at
    // its next checkpoint (after the current step), as a client's pause does, and a resume continues once
    // the store takes the history again.
    auto it = jobs_.find(id);
    if (it == jobs_.end()) return;
    auto& job = *it->second;
    if (job.record.state != job_state::running || !job.exec || job.exec->cancelled()) return;
    if (job.storage_failure.empty())
        log_->warn("job {}: pausing after the current step: its history cannot be stored", id);
    job.storage_failure = why;
    job.exec->request_pause();
}

void job_states::history_stored_again(const std::string& id) {
    // A job paused for its history waits for a client's resume now, which is possible again.
    auto job = jobs_.find(id);
    if (job != jobs_.end() && job->second->record.progress.waiting_for == job_wait::storage)
        set_waiting(*job->second, std::nullopt);
}

}  // namespace gw::jobs
