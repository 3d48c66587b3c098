#include "gateway/jobs/job_manager.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <fmt/format.h>
#include <map>
#include <mutex>

#include <boost/asio/append.hpp>
#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/redirect_error.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/asio/use_awaitable.hpp>
#include <spdlog/spdlog.h>

#include "devices/serial/controller_observer.hpp"
#include "gateway/common/job_id.hpp"
#include "gateway/config/logging.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/events/event_hub.hpp"
#include "gateway/jobs/job_execution.hpp"
#include "gateway/jobs/job_journal.hpp"
#include "gateway/jobs/job_json.hpp"
#include "gateway/jobs/job_kinds.hpp"
#include "gateway/jobs/job_lanes.hpp"
#include "gateway/jobs/job_store.hpp"
#include "gateway/jobs/job_store_handle.hpp"
#include "gateway/jobs/motion_probe.hpp"
#include "gateway/jobs/restore_ledger.hpp"
#include "gateway/jobs/safe_outputs.hpp"
#include "gateway/leases/lease_manager.hpp"

// g++ 12 reports a false -Wmismatched-new-delete at the end of some asio coroutines (the awaitable
// frame's own operator new/delete pair); clang and g++ 13 do not.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif

namespace gw::jobs {

namespace net = boost::asio;
using json = nlohmann::json;
using kind = operation_error_kind;

namespace {

// How long shutdown waits for running jobs to stop after their HALT before closing the store anyway.
constexpr std::chrono::milliseconds shutdown_grace{5000};

// How often writes that the job store refused are tried again.
constexpr std::chrono::milliseconds store_retry_interval{1000};

// Seconds the steps from `first` on still need: their motion, settle and dwell estimates. A step that
// waits for a trigger counts without its wait, which no one can predict (waiting_for shows it).
double remaining_from(const job_plan& plan, std::size_t first) {
    double s = 0;
    for (std::size_t i = first; i < plan.steps.size(); ++i)
        s += plan.steps[i].estimated_s;
    return s;
}

// progress.eta from remaining_s as of `now`: only a running job that waits for nothing unbounded has an
// end to expect.
void estimate_end(job_record& r, job_clock::time_point now) {
    auto& p = r.progress;
    const bool predictable =
        r.state == job_state::running && p.remaining_s && !(p.waiting_for && is_unbounded(*p.waiting_for));
    p.eta.reset();
    if (predictable)
        p.eta = now + std::chrono::duration_cast<job_clock::duration>(
                          std::chrono::duration<double>(std::max(0.0, *p.remaining_s)));
}

// gcode_file_store's directory (api/server.cpp makes the API's store on the same one).
std::filesystem::path gcode_files_directory(const job_manager_settings& s) {
    return s.storage_path.empty() ? std::filesystem::path{} : std::filesystem::path(s.storage_path) / "gcode";
}

std::string describe(const operation_error& e) {
    return e.message.empty() ? std::string(to_string(e.kind)) : e.message;
}

// The answer to a submission whose Idempotency-Key is already stored: the first job, when this is the
// same submission again (same client, controller, type and spec). A key reused for another request is
// refused rather than answered with a job that is not what was asked for; another client's job is not
// named.
operation_result<submit_result> replay(job_record first, const submit_request& r) {
    if (first.submitted_by != r.principal)
        return make_error(kind::invalid_value,
                          "this Idempotency-Key was used by another client: use a new key for this request",
                          "Idempotency-Key");
    if (first.controller != r.controller || first.type != r.type || first.spec != r.spec)
        return make_error(kind::invalid_value,
                          fmt::format("this Idempotency-Key was used for a different request (job {}): "
                                      "use a new key for a new request",
                                      first.id),
                          "Idempotency-Key");
    submit_result out;
    out.job = std::move(first);
    out.replayed = true;
    return out;
}

}  // namespace

// Everything the manager does, on one strand. Shared with the run() coroutines and the registry
// observer, so it outlives the job_manager object while they finish.
class manager_core final : public execution_host, public std::enable_shared_from_this<manager_core> {
  public:
    manager_core(net::any_io_executor executor, net::any_io_executor work_executor,
                 controller_registry& registry, std::shared_ptr<event_hub> hub,
                 std::shared_ptr<lease_manager> leases, job_manager_settings settings,
                 std::unique_ptr<job_store> store)
        : executor_(std::move(executor)),
          strand_(net::make_strand(std::move(work_executor))),
          registry_(registry),
          hub_(std::move(hub)),
          leases_(std::move(leases)),
          settings_(std::move(settings)),
          log_(get_logger("jobs")),
          store_(std::move(store)) {}

    void attach();
    void start();
    void shutdown(std::function<void()> done);
    void abandon();

    void submit(submit_request r, job_manager::handler<submit_result> h);
    void cancel(job_action a, job_manager::handler<job_record> h);
    void pause(job_action a, job_manager::handler<job_record> h);
    void resume(job_action a, job_manager::handler<job_record> h);
    void next(job_action a, job_manager::handler<job_record> h);
    void acquire_lease(std::string controller, std::string holder, std::chrono::seconds ttl,
                       job_manager::handler<lease> h);

    operation_result<job_record> get(const std::string& id) const;
    operation_result<job_page> list(const job_filter& f) const;
    operation_result<std::vector<json>> events(const std::string& id, std::size_t limit) const;

    // Registry observer events (controller strands): posted here.
    void controller_snapshot_changed(const devices::controller_snapshot& s);
    // The controller is connected (and identified) again after it was not.
    void controller_reconnected(const std::string& controller);
    // Connected and identified (the first time or again): sends what start() left pending for it.
    void controller_came_up(const std::string& controller);
    void controller_ttl_edge(const std::string& controller);

    // execution_host
    void on_step_started(live_job& job, std::size_t index) override;
    void on_step_done(live_job& job, std::size_t index, json detail) override;
    void on_emit(live_job& job, json event) override;
    void on_paused(live_job& job) override;
    void on_waiting(live_job& job, std::optional<job_wait> what) override;
    std::vector<json> step_events(const live_job& job) const override;
    std::filesystem::path gcode_files() const override { return gcode_files_directory(settings_); }
    void on_restore_commands_changed(live_job& job) override;

  private:
    template <typename T>
    void deliver(job_manager::handler<T> h, operation_result<T> r) {
        net::post(executor_, net::append(std::move(h), std::move(r)));
    }

    operation_result<std::shared_ptr<live_job>> find_live(const std::string& id);
    operation_result<void> check_lease(const std::string& controller, const job_action& a) const;
    // "j-1 running, j-2 queued": the jobs that hold the controller or wait for it; empty when none.
    std::string jobs_in_lane(const std::string& controller) const;

    void submit_planned(submit_request r, job_manager::handler<submit_result> h, motion_model model);
    void plan_again(std::shared_ptr<live_job> job, std::function<void(operation_result<void>)> done);

    // Changes the state, persists it (transition) and publishes {"type":"state",...}. `waiting`: what
    // the job waits for in its new state (a run sets its own waits: on_waiting).
    void set_state(live_job& job, job_state s, std::string reason,
                   std::optional<job_wait> waiting = std::nullopt);
    // Changes progress.waiting_for (and eta: unknown from the start of an unbounded wait, estimated again
    // at its end) and publishes it as a state event; nothing when it is the same.
    void set_waiting(live_job& job, std::optional<job_wait> what);
    // A job queued on `controller` now waits for it when another job holds it or is queued before it.
    std::optional<job_wait> queue_wait(const std::string& controller) const;
    // Stores the job's record (state, progress, a transition) and/or one of its events, in one
    // transaction, behind the job's writes that the store refused before (store_write). `progress`: the
    // write records what the job did (a step, a transition), so a refusal pauses it (store_refused); a
    // change of what it waits for does not (its step's write, queued behind it, will).
    void save(const std::string& id, std::optional<job_record> record, const json& event,
              bool progress = true);
    // Writes go through the job's queue of unstored writes, so that they reach the store in order:
    // appends `w`, then writes what is queued. A refusal keeps the rest queued (store_refused).
    void store_write(const std::string& id, job_journal::write w, bool progress = true);
    // journal_.write_pending; an ended job whose history is all stored is read from the store after it.
    operation_result<void> write_unstored(const std::string& id);
    // The store refused a write of the job: the writes are retried every store_retry_interval, and, for
    // a write of its progress, a running job pauses at its next checkpoint (nothing may run unrecorded).
    void store_refused(const std::string& id, const operation_error& e, bool progress);
    void retry_unstored_later();
    // Persists the job's restore commands (empty: removes them); a storage error is logged.
    void store_restore_commands(const std::string& id, const std::vector<std::string>& commands);
    // On the hub, for the job's topic (after save: a client never sees what is not stored first); the
    // topic of an ended job is retired settings_.ended_job_topic_ttl later.
    void publish(const job_record& job, const json& event);

    void dispatch(const std::string& controller);
    void launch(std::shared_ptr<live_job> job);
    void run_finished(std::shared_ptr<job_execution> exec, std::exception_ptr e);
    void release(const std::string& controller, const std::string& id);
    // HALT, "TTL Y=0", then the job's restore_if_stopped commands.
    net::awaitable<void> safe_stop(std::shared_ptr<live_job> job);
    // The job's restore_if_stopped commands, newest first; failures are logged.
    net::awaitable<void> restore_settings(std::shared_ptr<live_job> job);
    // "TTL Y=0" for a job paused by a disconnect (a laser must not stay on): once connected again.
    void ttl_low_after_disconnect(std::shared_ptr<live_job> job);
    // Sends "TTL Y=0"; the error message when it failed, empty when it went through.
    net::awaitable<std::string> ttl_output_low(std::string controller, std::string request_id);
    // For a job that a crash interrupted: "TTL Y=0" (safe_outputs.hpp), then its stored restore
    // commands newest first (as safe_stop does), once; what fails to reach the controller waits for the
    // next connect or the next run. Sent with safe_output_request_id(), not as the job's.
    void send_recovery(const std::string& controller);
    // Sends "TTL Y=0" when owed.ttl_low, then owed.restore newest first, under `request_id`. Returns
    // what did not reach the controller (a refusal did: it would be refused again), with its error.
    net::awaitable<std::pair<owed_restore, std::optional<operation_error>>> deliver(std::string controller,
                                                                                    std::string request_id,
                                                                                    owed_restore owed);
    // Keeps `rec` to send once the controller is connected. A recovery already pending there is kept
    // too, the older list first: sent newest first, a setting both runs changed ends at the older run's
    // value, the one from before either. Stored under the newer job.
    void add_recovery(const std::string& controller, owed_restore rec, bool rec_is_older = false);
    // start(): the stored restore commands of jobs that were not active (ended or interrupted before),
    // which an earlier run of the gateway could not deliver.
    void recover_undelivered_restores(const std::vector<job_record>& active);
    // Before a run starts: waits for a recovery being sent to the controller, then puts back what
    // earlier runs left changed there (a pending recovery, the job's own run that a disconnect ended),
    // so that the run reads the settings from before any job changed them. What does not reach the
    // controller stays in the job's restore commands, and the run does not start (job_failure).
    net::awaitable<void> put_back_before_run(std::shared_ptr<live_job> job);
    net::awaitable<void> shutdown_coro(std::function<void()> done);

    bool controller_connected(const std::string& id) const {
        auto s = registry_.get(id);
        return s && s->state == devices::connection_state::connected && s->identity;
    }

    net::any_io_executor executor_;             // where completion handlers without their own executor run
    net::strand<net::any_io_executor> strand_;  // everything else, store writes included
    controller_registry& registry_;
    std::shared_ptr<event_hub> hub_;
    std::shared_ptr<lease_manager> leases_;
    job_manager_settings settings_;
    std::shared_ptr<spdlog::logger> log_;

    // The store: written from the strand, read from get/list/events on any thread.
    job_store_handle store_;

    // Strand only, except live_records_ (under records_mutex_) which get() reads.
    std::map<std::string, std::shared_ptr<live_job>> jobs_;  // not terminal
    job_lanes lanes_;
    std::size_t running_ = 0;  // run() coroutines alive
    bool started_ = false;
    bool shutting_down_ = false;
    std::atomic<bool> abandoned_{false};
    mutable std::mutex records_mutex_;
    std::map<std::string, job_record> live_records_;
    // What interrupted jobs left on each controller that must still be undone (strand only); a run on
    // a controller a debt is being sent to (send_recovery) waits for it.
    restore_ledger restores_;
    // Each job's writes the store refused (disk full, read-only file), retried in order (strand only).
    // Kept after the job has ended: its final state must reach the store too. A running job pauses at its
    // next checkpoint, so usually only the steps until then wait there.
    job_journal journal_{store_, settings_.max_unstored_writes_per_job, log_};
    net::steady_timer store_retry_{strand_};
    bool store_retry_armed_ = false;

    std::shared_ptr<devices::controller_observer> observer_;

    friend class job_manager;
};

namespace {

// Forwards the registry's events to the core's strand; holds the core weakly.
class core_observer final : public devices::controller_observer {
  public:
    explicit core_observer(std::weak_ptr<manager_core> core) : core_(std::move(core)) {}
    void on_snapshot(const devices::controller_snapshot& s) override {
        const bool ready = s.state == devices::connection_state::connected && s.identity.has_value();
        bool came_back = false;
        bool came_up = false;  // the first snapshot seen, or came back
        {
            std::lock_guard lock(mutex_);  // controllers call from their own strands
            auto [it, added] = ready_.try_emplace(s.id, ready);
            came_back = ready && !added && !it->second;
            came_up = ready && (added || came_back);
            it->second = ready;
        }
        auto c = core_.lock();
        if (!c) return;
        if (came_up) c->controller_came_up(s.id);
        if (came_back) c->controller_reconnected(s.id);
        if (s.state == devices::connection_state::connected) return;  // otherwise only departures matter
        c->controller_snapshot_changed(s);
    }
    void on_report(const devices::report_event& e) override {
        if (auto c = core_.lock()) c->controller_ttl_edge(e.controller_id);
    }

  private:
    std::weak_ptr<manager_core> core_;
    std::mutex mutex_;
    std::map<std::string, bool> ready_;  // controller id -> connected and identified
};

}  // namespace

void manager_core::attach() {
    observer_ = std::make_shared<core_observer>(weak_from_this());
    registry_.add_observer(std::weak_ptr<devices::controller_observer>(observer_));
}

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
    auto& r = job.record;
    auto& p = r.progress;
    if (abandoned_ || p.waiting_for == what) return;
    // A run reports its waits while running; once stopped, set_state has said what it waits for.
    if (r.state != job_state::running && what != std::nullopt) return;
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

operation_result<std::vector<json>> manager_core::events(const std::string& id, std::size_t limit) const {
    auto store = store_.get();
    if (!store) return make_error(kind::storage_unavailable, "the job store is closed");
    auto found = store->find(id);
    if (!found) return found.error();
    if (!*found) return make_error(kind::unknown_job, "no job with id \"" + id + "\"", "id");
    return store->events(id, limit);
}

// ---------------------------------------------------------------------------------------------
// Start, shutdown, abandon.

void manager_core::start() {
    net::post(strand_, [self = shared_from_this()] {
        if (self->started_ || self->abandoned_) return;
        self->started_ = true;
        auto store = self->store_.get();
        if (!store) return;
        auto active = store->in_states({job_state::running, job_state::paused});
        auto queued = store->in_states({job_state::queued});
        if (!active)
            self->log_->error("restart recovery: cannot read the job store: {}", active.error().message);
        if (!queued)
            self->log_->error("restart recovery: cannot read the job store: {}", queued.error().message);
        // Restore commands an earlier run of the gateway could not deliver (a job cancelled, or stopped
        // by a shutdown, while its controller was unplugged): sent once the controller is connected.
        self->recover_undelivered_restores(active ? *active : std::vector<job_record>{});
        // A job that was active when the gateway stopped is not continued by itself: nothing is sent
        // twice to a controller. A client may resume it.
        for (auto& r : active ? *active : std::vector<job_record>{}) {
            auto job = std::make_shared<live_job>();
            job->record = std::move(r);
            self->jobs_[job->record.id] = job;
            self->set_state(*job, job_state::interrupted, "gateway restarted");
            owed_restore rec;
            rec.job_id = job->record.id;
            // A laser must never stay on: the crashed gateway could not switch the output off.
            rec.ttl_low = may_leave_ttl_output_high(job->record.type, job->record.spec);
            // Nor may the settings the run changed stay changed (an IN0 mode that still steps the stage).
            auto stored = store->restore_commands(job->record.id);
            if (stored)
                rec.restore = std::move(*stored);
            else
                self->log_->error("restart recovery: job {}: cannot read its restore commands: {}",
                                  job->record.id, stored.error().message);
            if (rec.ttl_low || !rec.restore.empty())
                self->add_recovery(job->record.controller, std::move(rec));
        }
        std::vector<std::string> reachable;
        for (const auto& controller : self->restores_.controllers_owed())
            if (self->controller_connected(controller)) reachable.push_back(controller);
        for (const auto& controller : reachable)
            self->send_recovery(controller);
        for (auto& r : queued ? *queued : std::vector<job_record>{}) {
            auto job = std::make_shared<live_job>();
            job->record = std::move(r);
            const auto id = job->record.id;
            const auto controller = job->record.controller;
            self->jobs_[id] = job;
            // Queued again, it waits for its controller (the first one starts at once); kept, for a resume.
            if (self->settings_.restart_queued) job->record.progress.waiting_for = job_wait::controller;
            {
                std::lock_guard lock(self->records_mutex_);
                self->live_records_[id] = job->record;
            }
            if (!self->settings_.restart_queued) continue;  // kept; `resume` queues it again
            job->queued_in_lane = true;
            self->lanes_.enqueue(controller, id);
        }
        for (const auto& controller : self->lanes_.controllers())
            self->dispatch(controller);
    });
}

void manager_core::shutdown(std::function<void()> done) {
    net::co_spawn(strand_, shutdown_coro(std::move(done)), net::detached);
}

net::awaitable<void> manager_core::shutdown_coro(std::function<void()> done) {
    auto self = shared_from_this();
    shutting_down_ = true;
    std::vector<std::shared_ptr<live_job>> to_stop;
    for (const auto& controller : lanes_.controllers()) {
        auto it = jobs_.find(lanes_.holder(controller));
        if (it == jobs_.end()) continue;
        auto job = it->second;
        const auto st = job->record.state;
        if (st != job_state::running && st != job_state::paused) continue;  // queued ones stay queued
        if (job->exec) {
            job->exec->cancel();
            to_stop.push_back(job);
        }
        set_state(*job, job_state::interrupted, "gateway shutting down");
    }
    for (auto& job : to_stop)
        co_await safe_stop(job);
    // The coroutines end at their next await (the HALT ends a move in progress).
    net::steady_timer timer(strand_);
    const auto deadline = std::chrono::steady_clock::now() + shutdown_grace;
    while (running_ > 0 && std::chrono::steady_clock::now() < deadline) {
        timer.expires_after(std::chrono::milliseconds(10));
        boost::system::error_code ec;
        co_await timer.async_wait(net::redirect_error(net::use_awaitable, ec));
    }
    if (running_ > 0) log_->warn("shutdown: {} job(s) did not stop in time", running_);
    // A last try for what the store refused; what it still refuses is lost, and said so.
    store_retry_.cancel();
    for (const auto& id : journal_.jobs_pending())
        if (auto stored = write_unstored(id); !stored)
            log_->error(
                "shutdown: job {}: {} write(s) of its history are lost (after a restart it shows its last "
                "stored state): {}",
                id, journal_.pending_count(id), stored.error().message);
    if (auto store = store_.close()) {
        if (auto ok = store->flush(); !ok)
            log_->error("shutdown: flushing the job store: {}", ok.error().message);
    }
    abandoned_ = true;  // nothing is written or published any more
    for (auto& [id, job] : jobs_)
        if (job->exec) job->exec->abandon();
    net::post(executor_, std::move(done));
}

void manager_core::abandon() {
    abandoned_ = true;
    {
        store_.close();  // like a crash: what was committed stays, nothing more is written
    }
    net::post(strand_, [self = shared_from_this()] {
        self->store_retry_.cancel();
        for (auto& [id, job] : self->jobs_)
            if (job->exec) job->exec->abandon();
    });
}

// ---------------------------------------------------------------------------------------------
// Submission.

void manager_core::submit(submit_request r, job_manager::handler<submit_result> h) {
    net::post(strand_, [self = shared_from_this(), r = std::move(r), h = std::move(h)]() mutable {
        if (self->shutting_down_ || self->abandoned_)
            return self->deliver<submit_result>(
                std::move(h), make_error(kind::not_connected, "the gateway is shutting down"));
        auto snapshot = self->registry_.get(r.controller);
        if (!snapshot)
            return self->deliver<submit_result>(
                std::move(h), make_error(kind::unknown_controller,
                                         "no controller with id \"" + r.controller + "\"", "controller"));
        if (self->leases_) {
            auto lease = self->leases_->check(
                r.controller, r.lease_id ? std::optional<std::string_view>(*r.lease_id) : std::nullopt);
            if (!lease) return self->deliver<submit_result>(std::move(h), lease.error());
        }
        if (r.idempotency_key && !r.dry_run) {
            auto store = self->store_.get();
            auto found = store ? store->find_by_idempotency_key(*r.idempotency_key)
                               : operation_result<std::optional<job_record>>(
                                     make_error(kind::storage_unavailable, "the job store is closed"));
            if (!found) return self->deliver<submit_result>(std::move(h), found.error());
            if (*found) return self->deliver<submit_result>(std::move(h), replay(std::move(**found), r));
        }
        const auto controller = r.controller;
        const auto rid = r.request_id;
        // std::function needs a copyable callable: the handler travels in a shared_ptr.
        auto shared_h = std::make_shared<job_manager::handler<submit_result>>(std::move(h));
        async_read_motion_model(
            self->registry_, controller, rid, [self, r = std::move(r), shared_h](motion_model model) mutable {
                net::post(self->strand_,
                          [self, r = std::move(r), shared_h, model = std::move(model)]() mutable {
                              self->submit_planned(std::move(r), std::move(*shared_h), std::move(model));
                          });
            });
    });
}

void manager_core::submit_planned(submit_request r, job_manager::handler<submit_result> h,
                                  motion_model model) {
    if (shutting_down_ || abandoned_)
        return deliver<submit_result>(std::move(h),
                                      make_error(kind::not_connected, "the gateway is shutting down"));
    auto snapshot = registry_.get(r.controller);
    if (!snapshot || snapshot->state != devices::connection_state::connected || !snapshot->identity)
        return deliver<submit_result>(
            std::move(h), make_error(kind::not_connected, fmt::format("{} is not connected: its build and "
                                                                      "limits are needed to plan the job",
                                                                      r.controller)));
    if (!r.spec.is_object())
        return deliver<submit_result>(std::move(h),
                                      make_error(kind::invalid_value, "spec must be a JSON object", "spec"));
    auto plan =
        plan_job(r.type, r.spec, plan_context{*snapshot, std::move(model), gcode_files_directory(settings_)});
    if (!plan) return deliver<submit_result>(std::move(h), plan.error());

    const auto now = job_clock::now();
    submit_result out;
    auto& rec = out.job;
    rec.controller = r.controller;
    rec.type = r.type;
    rec.spec = r.spec;
    rec.state = job_state::queued;
    rec.progress.steps_total = plan->steps.size();
    rec.progress.remaining_s = remaining_from(*plan, 0);
    rec.estimated_s = plan->estimated_s;
    rec.plan_path = plan->path;
    rec.idempotency_key = r.idempotency_key;
    rec.submitted_by = r.principal;
    rec.request_id = r.request_id;
    rec.created = now;
    rec.updated = now;
    if (r.dry_run) {
        out.plan = std::move(*plan);
        return deliver<submit_result>(std::move(h), std::move(out));
    }

    // Again, on the strand where leases are granted: one may have been taken while the job planned.
    if (leases_) {
        auto lease = leases_->check(r.controller,
                                    r.lease_id ? std::optional<std::string_view>(*r.lease_id) : std::nullopt);
        if (!lease) return deliver<submit_result>(std::move(h), lease.error());
    }
    if (const auto queued = lanes_.queued(r.controller); queued >= settings_.max_queued_per_controller)
        return deliver<submit_result>(
            std::move(h),
            make_error(kind::queue_full, fmt::format("{} already has {} queued jobs", r.controller, queued)));
    rec.id = make_job_id();
    rec.progress.waiting_for = queue_wait(r.controller);
    // Stored with the job, in one transaction: a store that cannot take the job's history refuses the
    // job, rather than letting it run unrecorded.
    const auto queued_event = state_event(rec, now);
    {
        auto store = store_.get();
        // Idempotency again: another submission with the key may have been stored while this one planned.
        if (store && r.idempotency_key) {
            auto found = store->find_by_idempotency_key(*r.idempotency_key);
            if (found && *found) return deliver<submit_result>(std::move(h), replay(std::move(**found), r));
        }
        auto inserted =
            store ? store->insert(rec, queued_event)
                  : operation_result<void>(make_error(kind::storage_unavailable, "the job store is closed"));
        if (!inserted) {
            auto e = inserted.error();
            if (e.kind != kind::storage_unavailable) e.kind = kind::storage_unavailable;
            log_->error("job submission for {} not stored: {}", r.controller, e.message);
            return deliver<submit_result>(std::move(h), std::move(e));
        }
    }
    auto job = std::make_shared<live_job>();
    job->record = rec;
    job->plan = *plan;
    job->queued_in_lane = true;
    jobs_[rec.id] = job;
    {
        std::lock_guard lock(records_mutex_);
        live_records_[rec.id] = rec;
    }
    if (hub_) hub_->publish(job_topic(rec.id), queued_event);  // stored by insert()
    log_->info("job {} ({} on {}) queued: {} steps, {:.1f} s estimated", rec.id, to_string(rec.type),
               rec.controller, rec.progress.steps_total, rec.estimated_s);
    lanes_.enqueue(r.controller, rec.id);
    out.plan = std::move(*plan);
    deliver<submit_result>(std::move(h), std::move(out));
    dispatch(r.controller);
}

void manager_core::plan_again(std::shared_ptr<live_job> job,
                              std::function<void(operation_result<void>)> done) {
    if (job->plan) return done({});
    const auto controller = job->record.controller;
    async_read_motion_model(
        registry_, controller, "job-" + job->record.id,
        [self = shared_from_this(), job, done = std::move(done)](motion_model model) mutable {
            net::post(self->strand_, [self, job, done = std::move(done), model = std::move(model)]() mutable {
                auto snapshot = self->registry_.get(job->record.controller);
                if (!snapshot || snapshot->state != devices::connection_state::connected ||
                    !snapshot->identity)
                    return done(
                        make_error(kind::not_connected, job->record.controller + " is not connected"));
                auto plan = plan_job(
                    job->record.type, job->record.spec,
                    plan_context{*snapshot, std::move(model), gcode_files_directory(self->settings_)});
                if (!plan) return done(plan.error());
                if (plan->steps.size() != job->record.progress.steps_total)
                    self->log_->warn("job {}: the plan now has {} steps, it had {}", job->record.id,
                                     plan->steps.size(), job->record.progress.steps_total);
                job->record.progress.steps_total = plan->steps.size();
                job->plan = std::move(*plan);
                done({});
            });
        });
}

// ---------------------------------------------------------------------------------------------
// Running.

void manager_core::dispatch(const std::string& controller) {
    if (shutting_down_ || abandoned_) return;
    const auto next = lanes_.take_next(controller, [this](const std::string& id) {
        auto it = jobs_.find(id);
        if (it == jobs_.end()) return false;
        it->second->queued_in_lane = false;
        return it->second->record.state == job_state::queued;
    });
    if (!next) return;
    auto job = jobs_.at(*next);
    if (job->plan) return launch(job);
    // Recovered after a restart: plans are not stored, so it is planned again first.
    lanes_.set_planning(controller, true);
    plan_again(job, [self = shared_from_this(), job, controller](operation_result<void> planned) {
        self->lanes_.set_planning(controller, false);
        if (job->record.state != job_state::queued || self->shutting_down_ || self->abandoned_) {
            self->release(controller, job->record.id);
            return;
        }
        if (!planned) {
            self->set_state(*job, job_state::failed,
                            "cannot plan the job again: " + describe(planned.error()));
            self->release(controller, job->record.id);
            return;
        }
        self->launch(job);
    });
}

void manager_core::launch(std::shared_ptr<live_job> job) {
    const auto first = std::min(job->record.progress.steps_done, job->plan->steps.size());
    job->ttl_low_on_reconnect = false;  // the run owns the output again
    auto exec = std::make_shared<job_execution>(strand_, registry_, weak_from_this(), job, first);
    job->exec = exec;
    job->record.progress.remaining_s = remaining_from(*job->plan, first);
    ++running_;
    set_state(*job, job_state::running, "");
    net::co_spawn(
        strand_,
        [self = shared_from_this(), job, exec]() -> net::awaitable<void> {
            co_await self->put_back_before_run(job);
            co_await run_job(*exec);
        },
        [self = shared_from_this(), exec](std::exception_ptr e) { self->run_finished(exec, e); });
}

void manager_core::run_finished(std::shared_ptr<job_execution> exec, std::exception_ptr e) {
    --running_;
    auto job = exec->live();
    if (job->exec == exec) job->exec.reset();
    if (abandoned_ || exec->abandoned() || job->stopping) return;  // a cancel in progress finishes it
    const auto controller = job->record.controller;
    const auto id = job->record.id;
    const auto st = job->record.state;
    if (st != job_state::running && st != job_state::paused) {
        // Cancelled or interrupted already (the manager set the state before the coroutine ended).
        release(controller, id);
        return;
    }
    std::string failure;
    bool disconnected = false;
    bool cancelled = false;
    try {
        if (e) std::rethrow_exception(e);
    } catch (const job_cancelled&) {
        cancelled = true;
    } catch (const job_failure& f) {
        failure = describe(f.error);
        // The registry's observer may have seen the disconnect first (exec->failure()), or the command
        // failed first and the snapshot says so.
        disconnected = f.error.kind == kind::not_connected || exec->failure().has_value() ||
                       !controller_connected(controller);
    } catch (const std::exception& x) {
        failure = std::string("internal error: ") + x.what();
    }
    if (!e) {
        set_state(*job, job_state::succeeded, "");
        store_restore_commands(id, {});  // the run put its settings back itself
        release(controller, id);
    } else if (cancelled) {
        set_state(*job, job_state::cancelled, "cancelled");
        release(controller, id);
    } else if (disconnected) {
        // The job keeps the controller: resume continues from the last completed step, once it is back.
        set_state(*job, job_state::paused, "controller disconnected: " + failure,
                  controller_connected(controller) ? std::nullopt : std::optional(job_wait::controller));
        const auto& r = job->restore_commands;
        if (std::find(r.begin(), r.end(), "TTL Y=0") != r.end()) {
            job->ttl_low_on_reconnect = true;
            if (controller_connected(controller)) ttl_low_after_disconnect(job);  // back already
        }
    } else {
        set_state(*job, job_state::failed, failure);
        // Put back what the job changed before the next job gets the controller.
        net::co_spawn(
            strand_,
            [self = shared_from_this(), job]() -> net::awaitable<void> {
                co_await self->restore_settings(job);
            },
            [self = shared_from_this(), controller, id](std::exception_ptr) {
                self->release(controller, id);
            });
    }
}

void manager_core::release(const std::string& controller, const std::string& id) {
    lanes_.release(controller, id);
    net::post(strand_, [self = shared_from_this(), controller] { self->dispatch(controller); });
}

net::awaitable<void> manager_core::safe_stop(std::shared_ptr<live_job> job) {
    // Named arguments only: g++ 12 mishandles temporaries that live across a co_await.
    const std::string controller = job->record.controller;
    const std::string request_id = "job-" + job->record.id;
    std::string halt_controller = controller;
    std::string halt_request_id = request_id;
    auto halted = co_await registry_.async_halt(std::move(halt_controller), std::move(halt_request_id),
                                                net::use_awaitable);
    if (!halted) log_->warn("[{}] {}: HALT failed: {}", request_id, controller, halted.error().message);
    const std::string ttl_failed = co_await ttl_output_low(controller, request_id);
    if (!ttl_failed.empty()) {
        log_->warn("[{}] {}: TTL Y=0 failed: {}", request_id, controller, ttl_failed);
        // Not delivered: it waits with the restore commands for the controller to be back.
        auto& r = job->restore_commands;
        if (may_leave_ttl_output_high(job->record.type, job->record.spec) &&
            std::find(r.begin(), r.end(), "TTL Y=0") == r.end())
            r.emplace_back("TTL Y=0");
    }
    co_await restore_settings(std::move(job));
}

net::awaitable<void> manager_core::restore_settings(std::shared_ptr<live_job> job) {
    const std::string controller = job->record.controller;
    const std::string request_id = "job-" + job->record.id;
    const auto restore = job->restore_commands;
    std::vector<std::string> undelivered;  // registration order, as stored
    for (auto it = restore.rbegin(); it != restore.rend(); ++it) {
        std::string restore_controller = controller;
        std::string restore_request_id = request_id;
        raw_command_request request{*it};
        auto r = co_await registry_.async_raw_command(std::move(restore_controller), std::move(request),
                                                      std::move(restore_request_id), net::use_awaitable);
        if (!r) {
            log_->warn("[{}] {}: restoring with \"{}\" failed: {}", request_id, controller, *it,
                       r.error().message);
            // It did not reach the controller (an answer, even a refusal, is not an error here).
            undelivered.insert(undelivered.begin(), *it);
        }
    }
    if (restore.empty()) co_return;
    // Kept in the store for the next start when the gateway is shutting down; otherwise sent once the
    // controller is connected again, or before the next run on it.
    store_restore_commands(job->record.id, undelivered);
    if (undelivered.empty() || shutting_down_) co_return;
    owed_restore rec;
    rec.job_id = job->record.id;
    rec.restore = std::move(undelivered);
    add_recovery(controller, std::move(rec));
    if (controller_connected(controller)) send_recovery(controller);
}

// ---------------------------------------------------------------------------------------------
// Leases.

void manager_core::acquire_lease(std::string controller, std::string holder, std::chrono::seconds ttl,
                                 job_manager::handler<lease> h) {
    net::post(strand_, [self = shared_from_this(), controller = std::move(controller),
                        holder = std::move(holder), ttl, h = std::move(h)]() mutable {
        if (!self->leases_)
            return self->deliver<lease>(std::move(h),
                                        make_error(kind::invalid_state, "leases are not enabled"));
        // Jobs submitted before the lease were not submitted under it: they must not move the stage
        // while it is exclusive, so the lease waits for them (submissions are checked on this strand).
        if (auto busy = self->jobs_in_lane(controller); !busy.empty())
            return self->deliver<lease>(
                std::move(h),
                make_error(kind::busy, fmt::format("{} has jobs that were submitted without this lease ({}): "
                                                   "wait for them to end or cancel them, then take the lease",
                                                   controller, busy)));
        self->deliver<lease>(std::move(h), self->leases_->acquire(controller, std::move(holder), ttl));
    });
}

std::string manager_core::jobs_in_lane(const std::string& controller) const {
    std::vector<std::string> parts;
    // A job that has ended (jobs_ keeps only the others) may hold the controller a little longer, until
    // its stop has been sent: it moves nothing more.
    const auto holder = lanes_.holder(controller);
    if (auto job = jobs_.find(holder); job != jobs_.end() && !is_terminal(job->second->record.state))
        parts.push_back(fmt::format("{} {}", holder, to_string(job->second->record.state)));
    for (const auto& id : lanes_.queue(controller))
        if (auto job = jobs_.find(id); job != jobs_.end() && job->second->record.state == job_state::queued)
            parts.push_back(id + " queued");
    std::string out;
    for (const auto& p : parts)
        out += (out.empty() ? "" : ", ") + p;
    return out;
}

// ---------------------------------------------------------------------------------------------
// Control actions.

operation_result<std::shared_ptr<live_job>> manager_core::find_live(const std::string& id) {
    if (auto it = jobs_.find(id); it != jobs_.end()) return it->second;
    {
        // Ended, but the store does not have its end yet (it refused it): the record in memory counts.
        std::lock_guard lock(records_mutex_);
        if (auto it = live_records_.find(id); it != live_records_.end() && is_terminal(it->second.state))
            return make_error(kind::invalid_state,
                              fmt::format("job {} has ended ({})", id, to_string(it->second.state)), "state");
    }
    std::optional<job_record> found;
    {
        auto store = store_.get();
        if (!store) return make_error(kind::storage_unavailable, "the job store is closed");
        auto r = store->find(id);
        if (!r) return r.error();
        found = std::move(*r);
    }
    if (!found) return make_error(kind::unknown_job, "no job with id \"" + id + "\"", "id");
    if (is_terminal(found->state))
        return make_error(kind::invalid_state,
                          fmt::format("job {} has ended ({})", id, to_string(found->state)), "state");
    // Not terminal but unknown here: an interrupted job from an earlier run of the gateway.
    auto job = std::make_shared<live_job>();
    job->record = std::move(*found);
    jobs_[id] = job;
    return job;
}

operation_result<void> manager_core::check_lease(const std::string& controller, const job_action& a) const {
    if (!leases_) return {};
    return leases_->check(controller,
                          a.lease_id ? std::optional<std::string_view>(*a.lease_id) : std::nullopt);
}

void manager_core::cancel(job_action a, job_manager::handler<job_record> h) {
    net::co_spawn(
        strand_,
        [self = shared_from_this(), a = std::move(a), h = std::move(h)]() mutable -> net::awaitable<void> {
            auto found = self->find_live(a.job_id);
            if (!found) co_return self->deliver<job_record>(std::move(h), found.error());
            auto job = *found;
            const auto controller = job->record.controller;
            if (auto lease = self->check_lease(controller, a); !lease)
                co_return self->deliver<job_record>(std::move(h), lease.error());
            const auto st = job->record.state;
            if (is_terminal(st))
                co_return self->deliver<job_record>(
                    std::move(h),
                    make_error(kind::invalid_state,
                               fmt::format("job {} has ended ({})", a.job_id, to_string(st)), "state"));
            if (st == job_state::queued || st == job_state::interrupted) {
                self->lanes_.remove(controller, a.job_id);
                job->queued_in_lane = false;
                self->set_state(*job, job_state::cancelled, "cancelled");
                co_return self->deliver<job_record>(std::move(h), job->record);
            }
            // Running or paused: stop the motion first, then the job. The controller stays the job's
            // until both the HALT/TTL and its run() are over, so the next job starts after them.
            job->stopping = true;
            if (job->exec) job->exec->cancel();
            co_await self->safe_stop(job);
            job->stopping = false;
            if (!is_terminal(job->record.state) && job->record.state != job_state::interrupted)
                self->set_state(*job, job_state::cancelled, "cancelled");
            if (!job->exec) self->release(controller, a.job_id);  // else run_finished releases it
            self->deliver<job_record>(std::move(h), job->record);
        },
        net::detached);
}

void manager_core::pause(job_action a, job_manager::handler<job_record> h) {
    net::post(strand_, [self = shared_from_this(), a = std::move(a), h = std::move(h)]() mutable {
        auto found = self->find_live(a.job_id);
        if (!found) return self->deliver<job_record>(std::move(h), found.error());
        auto job = *found;
        if (auto lease = self->check_lease(job->record.controller, a); !lease)
            return self->deliver<job_record>(std::move(h), lease.error());
        if (job->record.state == job_state::paused)
            return self->deliver<job_record>(std::move(h), job->record);
        if (job->record.state != job_state::running || !job->exec)
            return self->deliver<job_record>(
                std::move(h), make_error(kind::invalid_state,
                                         fmt::format("job {} is {}: only a running job can be paused",
                                                     a.job_id, to_string(job->record.state)),
                                         "state"));
        job->exec->request_pause();  // takes effect at the next checkpoint (after the current step)
        self->deliver<job_record>(std::move(h), job->record);
    });
}

void manager_core::resume(job_action a, job_manager::handler<job_record> h) {
    net::post(strand_, [self = shared_from_this(), a = std::move(a), h = std::move(h)]() mutable {
        if (self->shutting_down_ || self->abandoned_)
            return self->deliver<job_record>(std::move(h),
                                             make_error(kind::not_connected, "the gateway is shutting down"));
        auto found = self->find_live(a.job_id);
        if (!found) return self->deliver<job_record>(std::move(h), found.error());
        auto job = *found;
        const auto controller = job->record.controller;
        if (auto lease = self->check_lease(controller, a); !lease)
            return self->deliver<job_record>(std::move(h), lease.error());
        // Its history must be stored up to date before it runs on: its pause, and every step before it.
        if (auto stored = self->write_unstored(a.job_id); !stored)
            return self->deliver<job_record>(
                std::move(h),
                make_error(kind::storage_unavailable,
                           fmt::format("job {} cannot be resumed while the job store refuses its "
                                       "history: {}",
                                       a.job_id, stored.error().message)));
        job->storage_failure.clear();
        const auto st = job->record.state;
        const bool holds_controller = self->lanes_.holder(controller) == a.job_id;
        if (st == job_state::running && job->exec && job->exec->pause_requested()) {
            job->exec->resume();  // asked to pause, not paused yet: carry on
            return self->deliver<job_record>(std::move(h), job->record);
        }
        if (st == job_state::queued && !job->queued_in_lane && !holds_controller) {
            // Kept from before a restart (restart_queued off): queue it now.
            job->queued_in_lane = true;
            self->lanes_.enqueue(controller, a.job_id);
            self->dispatch(controller);
            return self->deliver<job_record>(std::move(h), job->record);
        }
        if (st != job_state::paused && st != job_state::interrupted)
            return self->deliver<job_record>(
                std::move(h),
                make_error(kind::invalid_state,
                           fmt::format("job {} is {}: only a paused or interrupted job can be resumed",
                                       a.job_id, to_string(st)),
                           "state"));
        if (!self->controller_connected(controller))
            return self->deliver<job_record>(
                std::move(h), make_error(kind::not_connected,
                                         fmt::format("{} is not connected; resume once it is", controller)));
        if (st == job_state::paused && job->exec && job->exec->waiting_paused()) {
            // Its run() waits at a checkpoint: it continues where it stopped.
            self->set_state(*job, job_state::queued, "");
            self->set_state(*job, job_state::running, "");
            job->exec->resume();
            return self->deliver<job_record>(std::move(h), job->record);
        }
        // A job that kept the controller while paused (a disconnect) goes first.
        self->set_state(*job, job_state::queued, "",
                        holds_controller ? std::nullopt : self->queue_wait(controller));
        job->queued_in_lane = true;
        if (holds_controller) self->lanes_.release(controller, a.job_id);
        self->lanes_.enqueue(controller, a.job_id, holds_controller);
        auto record = job->record;
        self->dispatch(controller);
        self->deliver<job_record>(std::move(h), std::move(record));
    });
}

void manager_core::next(job_action a, job_manager::handler<job_record> h) {
    net::post(strand_, [self = shared_from_this(), a = std::move(a), h = std::move(h)]() mutable {
        auto found = self->find_live(a.job_id);
        if (!found) return self->deliver<job_record>(std::move(h), found.error());
        auto job = *found;
        if (auto lease = self->check_lease(job->record.controller, a); !lease)
            return self->deliver<job_record>(std::move(h), lease.error());
        if (job->record.state != job_state::running || !job->exec)
            return self->deliver<job_record>(
                std::move(h), make_error(kind::invalid_state,
                                         fmt::format("job {} is {}: `next` needs a running job", a.job_id,
                                                     to_string(job->record.state)),
                                         "state"));
        job->exec->next();
        // The answer shows the wait over: the run takes this call as soon as it is back on the strand.
        if (job->record.progress.waiting_for == job_wait::next) self->set_waiting(*job, std::nullopt);
        self->deliver<job_record>(std::move(h), job->record);
    });
}

// ---------------------------------------------------------------------------------------------
// Controller events.

void manager_core::controller_snapshot_changed(const devices::controller_snapshot& s) {
    net::post(strand_, [self = shared_from_this(), id = s.id, state = s.state] {
        auto job = self->jobs_.find(self->lanes_.holder(id));
        if (job == self->jobs_.end() || !job->second->exec) return;
        if (job->second->exec->waiting_paused()) return;  // paused by a client: resume finds out
        job->second->exec->fail(
            make_error(kind::not_connected, fmt::format("{} is {}", id, devices::to_string(state))));
    });
}

void manager_core::controller_reconnected(const std::string& controller) {
    net::post(strand_, [self = shared_from_this(), controller] {
        auto job = self->jobs_.find(self->lanes_.holder(controller));
        if (job == self->jobs_.end()) return;
        // Paused by the disconnect: it waits for a client's resume now, which is possible again.
        if (job->second->record.progress.waiting_for == job_wait::controller)
            self->set_waiting(*job->second, std::nullopt);
        if (!job->second->ttl_low_on_reconnect) return;
        self->ttl_low_after_disconnect(job->second);
    });
}

void manager_core::controller_came_up(const std::string& controller) {
    net::post(strand_, [self = shared_from_this(), controller] {
        if (self->restores_.owes(controller)) self->send_recovery(controller);
    });
}

void manager_core::add_recovery(const std::string& controller, owed_restore rec, bool rec_is_older) {
    auto added = restores_.add(controller, std::move(rec), rec_is_older);
    if (!added.merged) return;
    store_restore_commands(added.now.job_id, added.now.restore);
    if (added.superseded_job) {
        log_->info("{}: the restore commands of job {} are kept with those of job {}", controller,
                   *added.superseded_job, added.now.job_id);
        store_restore_commands(*added.superseded_job, {});
    }
}

void manager_core::recover_undelivered_restores(const std::vector<job_record>& active) {
    auto store = store_.get();
    if (!store) return;
    auto ids = store->jobs_with_restore_commands();
    if (!ids) {
        log_->error("restart recovery: cannot list the stored restore commands: {}", ids.error().message);
        return;
    }
    for (const auto& id : *ids) {
        const bool was_active =
            std::any_of(active.begin(), active.end(), [&](const job_record& r) { return r.id == id; });
        if (was_active) continue;  // start() recovers those with their TTL output
        auto found = store->find(id);
        auto commands = store->restore_commands(id);
        if (!found || !*found || !commands || commands->empty()) continue;
        owed_restore rec;
        rec.job_id = id;
        rec.restore = std::move(*commands);
        add_recovery((*found)->controller, std::move(rec));
    }
}

net::awaitable<void> manager_core::put_back_before_run(std::shared_ptr<live_job> job) {
    const std::string controller = job->record.controller;
    const std::string id = job->record.id;
    net::steady_timer wait(strand_);
    while (restores_.sending(controller) && !abandoned_) {
        wait.expires_after(std::chrono::milliseconds(10));
        boost::system::error_code ec;
        co_await wait.async_wait(net::redirect_error(net::use_awaitable, ec));
    }
    if (abandoned_) co_return;
    owed_restore owed = restores_.take(controller);
    const std::string earlier_job = owed.job_id;
    owed.job_id = id;
    for (const auto& c : job->restore_commands)
        if (std::find(owed.restore.begin(), owed.restore.end(), c) == owed.restore.end())
            owed.restore.push_back(c);
    if (!owed.ttl_low && owed.restore.empty()) co_return;
    // The job owns the list now: stored under it before the earlier job's row goes (a crash between
    // the two leaves both, and start() sends both).
    job->restore_commands = owed.restore;
    store_restore_commands(id, job->restore_commands);
    if (!earlier_job.empty() && earlier_job != id) store_restore_commands(earlier_job, {});

    const std::string request_id = safe_output_request_id(id);
    auto [left, error] = co_await deliver(controller, request_id, owed);
    for (const auto& c : owed.restore)
        if (std::find(left.restore.begin(), left.restore.end(), c) == left.restore.end())
            std::erase(job->restore_commands, c);
    auto& r = job->restore_commands;
    if (left.ttl_low && std::find(r.begin(), r.end(), "TTL Y=0") == r.end()) r.emplace_back("TTL Y=0");
    store_restore_commands(id, r);
    const std::size_t total = owed.restore.size() + (owed.ttl_low ? 1 : 0);
    const std::size_t undelivered = left.restore.size() + (left.ttl_low ? 1 : 0);
    log_->info("[{}] {}: before job {} runs, {} of {} command(s) put back what earlier runs left changed",
               request_id, controller, id, total - undelivered, total);
    if (!error) co_return;
    auto e = *error;
    e.message = fmt::format("{}: what an earlier run left changed could not be put back: {}", controller,
                            describe(*error));
    throw job_failure(std::move(e));
}

void manager_core::send_recovery(const std::string& controller) {
    if (!restores_.owes(controller) || abandoned_ || restores_.sending(controller)) return;
    owed_restore pending = restores_.take(controller);
    restores_.start_sending(controller);
    net::co_spawn(
        strand_,
        [self = shared_from_this(), controller, pending = std::move(pending)]() -> net::awaitable<void> {
            const std::string job_id = pending.job_id;
            const std::string request_id = safe_output_request_id(job_id);
            auto [left, error] = co_await self->deliver(controller, request_id, pending);
            if (pending.ttl_low && !left.ttl_low)
                self->log_->info("[{}] {}: job {} was interrupted by a restart; TTL output set low",
                                 request_id, controller, job_id);
            const auto& restore = pending.restore;
            if (!restore.empty())
                self->log_->info(
                    "[{}] {}: job {} was interrupted by a restart; {} of its {} restore "
                    "command(s) sent",
                    request_id, controller, job_id, restore.size() - left.restore.size(), restore.size());
            self->restores_.done_sending(controller);
            if (!restore.empty()) self->store_restore_commands(job_id, left.restore);
            // Added while this one was being sent (a job that failed meanwhile): sent next.
            const bool more = self->restores_.owes(controller);
            // What did not reach the controller waits for its next connect, or for the next run on it.
            if (left.ttl_low || !left.restore.empty()) self->add_recovery(controller, std::move(left), true);
            if (more && self->controller_connected(controller)) self->send_recovery(controller);
        },
        net::detached);
}

net::awaitable<std::pair<owed_restore, std::optional<operation_error>>> manager_core::deliver(
    std::string controller, std::string request_id, owed_restore owed) {
    owed_restore left;
    left.job_id = owed.job_id;
    std::optional<operation_error> error;
    if (owed.ttl_low) {
        const std::string ttl_failed = co_await ttl_output_low(controller, request_id);
        if (!ttl_failed.empty()) {
            log_->warn("[{}] {}: TTL Y=0 for job {} failed: {}", request_id, controller, owed.job_id,
                       ttl_failed);
            left.ttl_low = true;
            error = make_error(controller_connected(controller) ? kind::timeout : kind::not_connected,
                               "TTL Y=0 failed: " + ttl_failed);
        }
    }
    const auto& restore = owed.restore;
    for (auto r = restore.rbegin(); r != restore.rend(); ++r) {
        // Sent just above (or kept for the next try) when the output is switched off anyway.
        if (owed.ttl_low && *r == "TTL Y=0") {
            if (left.ttl_low) left.restore.insert(left.restore.begin(), *r);
            continue;
        }
        std::string restore_controller = controller;
        std::string restore_request_id = request_id;
        raw_command_request request{*r};
        auto sent = co_await registry_.async_raw_command(std::move(restore_controller), std::move(request),
                                                         std::move(restore_request_id), net::use_awaitable);
        if (!sent) {
            log_->warn("[{}] {}: restoring with \"{}\" for job {} failed: {}", request_id, controller, *r,
                       owed.job_id, sent.error().message);
            left.restore.insert(left.restore.begin(), *r);
            if (!error) error = sent.error();
        } else if (sent->reply.what == devices::ms2000::reply::kind::error) {
            log_->warn("[{}] {}: the controller refused \"{}\" (restore for job {}): {}", request_id,
                       controller, *r, owed.job_id, sent->raw_reply);
        }
    }
    co_return std::pair{std::move(left), std::move(error)};
}

net::awaitable<std::string> manager_core::ttl_output_low(std::string controller, std::string request_id) {
    ttl_request low;
    low.output_high = false;  // "TTL Y=0"
    auto ttl =
        co_await registry_.async_ttl(std::move(controller), low, std::move(request_id), net::use_awaitable);
    co_return ttl ? std::string() : ttl.error().message;
}

void manager_core::ttl_low_after_disconnect(std::shared_ptr<live_job> job) {
    if (!job->ttl_low_on_reconnect || abandoned_) return;
    job->ttl_low_on_reconnect = false;
    net::co_spawn(
        strand_,
        [self = shared_from_this(), job]() -> net::awaitable<void> {
            const std::string controller = job->record.controller;
            const std::string request_id = "job-" + job->record.id;
            const std::string ttl_failed = co_await self->ttl_output_low(controller, request_id);
            if (ttl_failed.empty()) {
                self->log_->info("[{}] {}: connected again; TTL output set low", request_id, controller);
            } else {
                self->log_->warn("[{}] {}: TTL Y=0 after the reconnect failed: {}", request_id, controller,
                                 ttl_failed);
                // The next reconnect tries again, unless the job runs again meanwhile.
                job->ttl_low_on_reconnect = job->record.state == job_state::paused;
            }
        },
        net::detached);
}

void manager_core::controller_ttl_edge(const std::string& controller) {
    net::post(strand_, [self = shared_from_this(), controller] {
        auto job = self->jobs_.find(self->lanes_.holder(controller));
        if (job != self->jobs_.end() && job->second->exec) job->second->exec->ttl_edge();
    });
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

// ---------------------------------------------------------------------------------------------
// job_manager

struct job_manager::impl {
    std::shared_ptr<manager_core> core;
};

operation_result<std::shared_ptr<job_manager>> job_manager::create(net::any_io_executor executor,
                                                                   controller_registry& registry,
                                                                   std::shared_ptr<event_hub> hub,
                                                                   std::shared_ptr<lease_manager> leases,
                                                                   job_manager_settings settings) {
    auto work_executor = executor;
    return create(std::move(executor), std::move(work_executor), registry, std::move(hub), std::move(leases),
                  std::move(settings));
}

operation_result<std::shared_ptr<job_manager>> job_manager::create(
    net::any_io_executor executor, net::any_io_executor work_executor, controller_registry& registry,
    std::shared_ptr<event_hub> hub, std::shared_ptr<lease_manager> leases, job_manager_settings settings) {
    job_store_options options;
    options.max_size_mb = settings.storage_max_size_mb;
    auto store = job_store::open(settings.storage_path, options);
    if (!store) return store.error();
    return std::shared_ptr<job_manager>(new job_manager(std::move(executor), std::move(work_executor),
                                                        registry, std::move(hub), std::move(leases),
                                                        std::move(settings), std::move(*store)));
}

job_manager::job_manager(net::any_io_executor executor, net::any_io_executor work_executor,
                         controller_registry& registry, std::shared_ptr<event_hub> hub,
                         std::shared_ptr<lease_manager> leases, job_manager_settings settings,
                         std::unique_ptr<job_store> store)
    : impl_(std::make_unique<impl>()) {
    impl_->core = std::make_shared<manager_core>(std::move(executor), std::move(work_executor), registry,
                                                 std::move(hub), std::move(leases), std::move(settings),
                                                 std::move(store));
    impl_->core->attach();
}

job_manager::~job_manager() {
    impl_->core->abandon();
}

void job_manager::start() {
    impl_->core->start();
}

void job_manager::async_shutdown(std::function<void()> done) {
    impl_->core->shutdown(std::move(done));
}

void job_manager::async_submit(submit_request request, handler<submit_result> h) {
    impl_->core->submit(std::move(request), std::move(h));
}

operation_result<job_record> job_manager::get(const std::string& id) const {
    return impl_->core->get(id);
}

operation_result<job_page> job_manager::list(const job_filter& filter) const {
    return impl_->core->list(filter);
}

operation_result<std::vector<nlohmann::json>> job_manager::events(const std::string& id,
                                                                  std::size_t limit) const {
    return impl_->core->events(id, limit);
}

void job_manager::async_cancel(job_action a, handler<job_record> h) {
    impl_->core->cancel(std::move(a), std::move(h));
}

void job_manager::async_pause(job_action a, handler<job_record> h) {
    impl_->core->pause(std::move(a), std::move(h));
}

void job_manager::async_resume(job_action a, handler<job_record> h) {
    impl_->core->resume(std::move(a), std::move(h));
}

void job_manager::async_next(job_action a, handler<job_record> h) {
    impl_->core->next(std::move(a), std::move(h));
}

void job_manager::async_acquire_lease(std::string controller, std::string holder, std::chrono::seconds ttl,
                                      handler<lease> h) {
    impl_->core->acquire_lease(std::move(controller), std::move(holder), ttl, std::move(h));
}

}  // namespace gw::jobs
