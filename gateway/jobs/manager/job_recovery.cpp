#include "gateway/jobs/manager/job_recovery.hpp"

#include <algorithm>
#include <fmt/format.h>

#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/redirect_error.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/use_awaitable.hpp>
#include <spdlog/spdlog.h>

#include "gateway/controllers/controller_registry.hpp"
#include "gateway/jobs/kinds/safe_outputs.hpp"
#include "gateway/jobs/manager/job_history.hpp"

namespace gw::jobs {

namespace net = boost::asio;
using kind = operation_error_kind;

job_recovery::job_recovery(net::strand<net::any_io_executor> strand, controller_registry& registry,
                           std::shared_ptr<job_history> history, std::shared_ptr<spdlog::logger> log)
    : strand_(std::move(strand)), registry_(registry), history_(std::move(history)), log_(std::move(log)) {}

bool job_recovery::connected(const std::string& controller) const {
    auto s = registry_.get(controller);
    return s && s->state == devices::connection_state::connected && s->identity;
}

void job_recovery::controller_came_up(const std::string& controller) {
    if (restores_.owes(controller)) send(controller);
}

void job_recovery::send_owed_to_connected() {
    std::vector<std::string> reachable;
    for (const auto& controller : restores_.controllers_owed())
        if (connected(controller)) reachable.push_back(controller);
    for (const auto& controller : reachable)
        send(controller);
}

net::awaitable<void> job_recovery::safe_stop(std::shared_ptr<live_job> job) {
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

net::awaitable<void> job_recovery::secure_after_halt(std::shared_ptr<live_job> job) {
    const std::string controller = job->record.controller;
    const std::string request_id = "job-" + job->record.id;
    if (may_leave_ttl_output_high(job->record.type, job->record.spec)) {
        const std::string ttl_failed = co_await ttl_output_low(controller, request_id);
        auto& r = job->restore_commands;
        if (!ttl_failed.empty() && std::find(r.begin(), r.end(), "TTL Y=0") == r.end())
            r.emplace_back("TTL Y=0");
    }
    co_await restore_settings(job);
    // Delivered, or owed to the controller (restores_): the resumed run starts from the settings as they
    // were before the job, and puts back what is owed first (put_back_before_run).
    job->restore_commands.clear();
    log_->info("[{}] {}: job {} halted; outputs and settings made safe", request_id, controller,
               job->record.id);
}

net::awaitable<operation_result<raw_command_result>> job_recovery::send_restore(std::string controller,
                                                                                std::string request_id,
                                                                                std::string command) {
    raw_command_request request{std::move(command)};
    co_return co_await registry_.async_raw_command(std::move(controller), std::move(request),
                                                   std::move(request_id), net::use_awaitable);
}

net::awaitable<void> job_recovery::restore_settings(std::shared_ptr<live_job> job) {
    const std::string controller = job->record.controller;
    const std::string request_id = "job-" + job->record.id;
    const auto restore = job->restore_commands;
    std::vector<std::string> undelivered;  // registration order, as stored
    for (auto it = restore.rbegin(); it != restore.rend(); ++it) {
        auto r = co_await send_restore(controller, request_id, *it);
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
    history_->store_restore_commands(job->record.id, undelivered);
    if (undelivered.empty() || shutting_down_) co_return;
    owed_restore rec;
    rec.job_id = job->record.id;
    rec.restore = std::move(undelivered);
    owe(controller, std::move(rec));
    if (connected(controller)) send(controller);
}

void job_recovery::owe(const std::string& controller, owed_restore rec, bool rec_is_older) {
    auto added = restores_.add(controller, std::move(rec), rec_is_older);
    if (!added.merged) return;
    history_->store_restore_commands(added.now.job_id, added.now.restore);
    if (added.superseded_job) {
        log_->info("{}: the restore commands of job {} are kept with those of job {}", controller,
                   *added.superseded_job, added.now.job_id);
        history_->store_restore_commands(*added.superseded_job, {});
    }
}

void job_recovery::recover_undelivered(const std::vector<job_record>& active) {
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
        owe((*found)->controller, std::move(rec));
    }
}

net::awaitable<void> job_recovery::put_back_before_run(std::shared_ptr<live_job> job) {
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

void job_recovery::send(const std::string& controller) {
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
            if (!left.empty()) self->owe(controller, std::move(left), true);
            if (more && self->connected(controller)) self->send(controller);
        },
        net::detached);
}

net::awaitable<std::pair<owed_restore, std::optional<operation_error>>> job_recovery::deliver(
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
            error = make_error(connected(controller) ? kind::timeout : kind::not_connected,
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
        auto sent = co_await send_restore(controller, request_id, *r);
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

net::awaitable<std::string> job_recovery::ttl_output_low(std::string controller, std::string request_id) {
    ttl_request low;
    low.output_high = false;  // "TTL Y=0"
    auto ttl =
        co_await registry_.async_ttl(std::move(controller), low, std::move(request_id), net::use_awaitable);
    co_return ttl ? std::string() : ttl.error().message;
}

void job_recovery::ttl_low_after_disconnect(const std::shared_ptr<live_job>& job) {
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
