#include "gateway/jobs/job_manager_core.hpp"

namespace gw::jobs {

// ---------------------------------------------------------------------------------------------
// What stopped or crashed runs owe a controller.

void manager_core::controller_came_up(const std::string& controller) {
    net::post(strand_, [self = shared_from_this(), controller] {
        if (self->restores_.owes(controller)) self->send_recovery(controller);
    });
}

void manager_core::add_recovery(const std::string& controller, owed_restore rec, bool rec_is_older) {
    auto added = restores_.add(controller, std::move(rec), rec_is_older);
    if (!added.merged) return;
    history_->store_restore_commands(added.now.job_id, added.now.restore);
    if (added.superseded_job) {
        log_->info("{}: the restore commands of job {} are kept with those of job {}", controller,
                   *added.superseded_job, added.now.job_id);
        history_->store_restore_commands(*added.superseded_job, {});
    }
}

void manager_core::recover_undelivered_restores(const std::vector<job_record>& active) {
    auto store = history_->store().get();
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
    if (owed.empty()) co_return;
    // The job owns the list now: stored under it before the earlier job's row goes (a crash between
    // the two leaves both, and start() sends both).
    job->restore_commands = owed.restore;
    history_->store_restore_commands(id, job->restore_commands);
    if (!earlier_job.empty() && earlier_job != id) history_->store_restore_commands(earlier_job, {});

    const std::string request_id = safe_output_request_id(id);
    auto [left, error] = co_await deliver(controller, request_id, owed);
    for (const auto& c : owed.restore)
        if (std::find(left.restore.begin(), left.restore.end(), c) == left.restore.end())
            std::erase(job->restore_commands, c);
    auto& r = job->restore_commands;
    if (left.ttl_low && std::find(r.begin(), r.end(), "TTL Y=0") == r.end()) r.emplace_back("TTL Y=0");
    history_->store_restore_commands(id, r);
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
            if (!restore.empty()) self->history_->store_restore_commands(job_id, left.restore);
            // Added while this one was being sent (a job that failed meanwhile): sent next.
            const bool more = self->restores_.owes(controller);
            // What did not reach the controller waits for its next connect, or for the next run on it.
            if (!left.empty()) self->add_recovery(controller, std::move(left), true);
            if (more && self->controller_connected(controller)) self->send_recovery(controller);
        },
        net::detached);
}

net::awaitable<std::pair<owed_restore, std::optional<operation_error>>> manager_core::deliver(
    std::string controller, std::string request_id, owed_restore owed) {
    owed_restore left;
    left.job_id = owed.job_id;
    std::optional<operation_error> error;
    if (owed.halt) {
        // Before anything else: the stage may still be moving where the gateway went down.
        std::string halt_controller = controller;
        std::string halt_request_id = request_id;
        auto halted = co_await registry_.async_halt(std::move(halt_controller), std::move(halt_request_id),
                                                    net::use_awaitable);
        if (!halted) {
            log_->warn("[{}] {}: HALT for job {} failed: {}", request_id, controller, owed.job_id,
                       halted.error().message);
            left.halt = true;
            error = halted.error();
            co_return std::pair{std::move(owed), std::move(error)};  // nothing else before the HALT
        }
        log_->info("[{}] {}: job {} was running when the gateway went down: HALT sent first", request_id,
                   controller, owed.job_id);
    }
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

}  // namespace gw::jobs
