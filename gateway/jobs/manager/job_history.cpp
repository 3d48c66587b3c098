#include "gateway/jobs/manager/job_history.hpp"

#include <boost/asio/append.hpp>
#include <boost/asio/post.hpp>
#include <spdlog/spdlog.h>

#include "gateway/common/history_retention.hpp"
#include "gateway/events/event_hub.hpp"
#include "gateway/jobs/job_json.hpp"

namespace gw::jobs {

namespace net = boost::asio;
using json = nlohmann::json;
using kind = operation_error_kind;

// A write the store refuses (disk full, read-only file) is never dropped: it waits in the job's queue in
// journal_, later writes of the job queue behind it (the history stays in order), and the queue is
// written again every store_retry_interval, before a resume (which is refused until it is stored) and at
// a clean shutdown. Meanwhile the record in memory is the truth, and get() answers from it.

job_history::job_history(net::strand<net::any_io_executor> strand, net::any_io_executor executor,
                         std::shared_ptr<event_hub> hub, job_manager_settings settings,
                         std::shared_ptr<spdlog::logger> log, std::unique_ptr<job_store> store)
    : strand_(std::move(strand)),
      executor_(std::move(executor)),
      hub_(std::move(hub)),
      settings_(std::move(settings)),
      log_(std::move(log)),
      store_(std::move(store)) {}

void job_history::start() {
    note_store_fill(true);
    sweep();
}

void job_history::record(const std::string& id, std::optional<job_record> record, const json& event,
                         bool progress) {
    if (stopped_) return;
    const std::optional<job_record> saved = record;
    if (auto stored = journal_.append(id, job_journal::write{std::move(record), event}); !stored)
        store_refused(id, stored.error(), progress);
    note_store_fill();
    if (!saved) return;
    // get() answers from memory for active jobs, and for ended ones until the store has their end. Set
    // after the write: what get() shows of a step is stored (unless the store refused it).
    std::lock_guard lock(records_mutex_);
    if (is_terminal(saved->state) && !journal_.has_pending(id))
        remembered_.erase(id);
    else
        remembered_[id] = *saved;
}

void job_history::publish(const job_record& job, const json& event) {
    if (stopped_ || !hub_) return;
    hub_->publish(job_topic(job.id), event);
    // Once the job has ended, its topic retires a while after its last event (a later event moves the
    // time): the hub would otherwise keep every job's replay buffer for ever.
    if (is_terminal(job.state)) hub_->retire_topic(job_topic(job.id), settings_.ended_job_topic_ttl);
}

void job_history::remember(const job_record& r) {
    std::lock_guard lock(records_mutex_);
    remembered_[r.id] = r;
}

void job_history::note_store_fill(bool now) {
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

void job_history::sweep(std::size_t deleted_so_far) {
    const auto& retention = settings_.retention;
    if (stopped_ || shutting_down_ || retention.keeps_all_jobs()) return;
    auto store = store_.get();
    if (!store) return;
    std::optional<job_clock::time_point> ended_before;
    if (retention.max_age) ended_before = job_clock::now() - *retention.max_age;
    auto deleted = store->delete_ended(ended_before, retention.max_ended_jobs, retention_batch);
    if (!deleted) log_->warn("storage.retention: cannot delete ended jobs: {}", deleted.error().message);
    const std::size_t n = deleted ? *deleted : 0;
    if (n == retention_batch)  // more left: the next batch after what else waits on the strand
        return net::post(strand_,
                         [self = shared_from_this(), total = deleted_so_far + n] { self->sweep(total); });
    if (deleted_so_far + n > 0) {
        log_->info("storage.retention: deleted {} ended job(s) with their history", deleted_so_far + n);
        note_store_fill(true);
    }
    sweep_timer_.expires_after(retention.sweep_interval);
    sweep_timer_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
        if (!ec) self->sweep();
    });
}

operation_result<void> job_history::write_unstored(const std::string& id) {
    bool ended = false;
    auto stored = journal_.write_pending(id, &ended);
    // An ended job is read from the store from now on.
    if (stored && ended) {
        std::lock_guard lock(records_mutex_);
        remembered_.erase(id);
    }
    return stored;
}

void job_history::store_refused(const std::string& id, const operation_error& e, bool progress) {
    if (journal_.refused(id, e.message))
        log_->error("job {}: the job store refused its history ({} write(s) kept, retried every {} ms): {}",
                    id, journal_.pending_count(id), store_retry_interval.count(), e.message);
    retry_unstored_later();
    if (!progress) return;
    if (auto o = owner_.lock()) o->history_refused(id, e.message);
}

void job_history::retry_unstored_later() {
    if (retry_armed_ || stopped_) return;
    retry_armed_ = true;
    retry_timer_.expires_after(store_retry_interval);
    retry_timer_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
        self->retry_armed_ = false;
        if (ec || self->stopped_) return;
        for (const auto& id : self->journal_.jobs_pending()) {
            if (auto stored = self->write_unstored(id); !stored) {
                self->journal_.refused(id, stored.error().message);
                continue;
            }
            if (auto o = self->owner_.lock()) o->history_stored_again(id);
        }
        if (!self->journal_.empty()) self->retry_unstored_later();
    });
}

void job_history::store_restore_commands(const std::string& id, const std::vector<std::string>& commands) {
    if (stopped_) return;
    auto store = store_.get();
    if (!store) return;
    if (auto ok = store->set_restore_commands(id, commands); !ok)
        log_->error("job {}: cannot store its restore commands: {}", id, ok.error().message);
}

std::vector<json> job_history::step_events(const std::string& id) const {
    constexpr std::size_t all = 1'000'000;
    auto store = store_.get();
    if (!store) return {};
    auto stored = store->events(id, all);
    if (!stored) return {};
    // Then those the store has not taken yet, which follow them.
    for (auto& e : journal_.pending_events(id))
        stored->push_back(std::move(e));
    std::vector<json> out;
    for (auto& e : *stored)
        if (e.is_object() && e.value("type", "") == "step") out.push_back(std::move(e));
    return out;
}

void job_history::stop() {
    retry_timer_.cancel();
    sweep_timer_.cancel();
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
    stopped_ = true;
}

void job_history::abandon() {
    stopped_ = true;
    store_.close();  // like a crash: what was committed stays, nothing more is written
    net::post(strand_, [self = shared_from_this()] {
        self->retry_timer_.cancel();
        self->sweep_timer_.cancel();
    });
}

// ---- any thread ----

operation_result<job_record> job_history::get(const std::string& id) const {
    if (auto r = remembered(id)) return std::move(*r);
    auto store = store_.get();
    if (!store) return make_error(kind::storage_unavailable, "the job store is closed");
    auto found = store->find(id);
    if (!found) return found.error();
    if (!*found) return make_error(kind::unknown_job, "no job with id \"" + id + "\"", "id");
    return std::move(**found);
}

std::optional<job_record> job_history::remembered(const std::string& id) const {
    std::lock_guard lock(records_mutex_);
    if (auto it = remembered_.find(id); it != remembered_.end()) return it->second;
    return std::nullopt;
}

operation_result<job_page> job_history::list(const job_filter& f) const {
    auto store = store_.get();
    if (!store) return make_error(kind::storage_unavailable, "the job store is closed");
    auto page = store->list(f);
    if (!page) return page;
    // Active jobs as get() shows them: with what they wait for and their eta (which the store does not
    // keep), and their latest progress.
    std::lock_guard lock(records_mutex_);
    for (auto& j : page->jobs)
        if (auto it = remembered_.find(j.id); it != remembered_.end()) j = it->second;
    return page;
}

operation_result<std::vector<json>> job_history::events(const std::string& id, std::size_t limit) const {
    auto store = store_.get();
    if (!store) return make_error(kind::storage_unavailable, "the job store is closed");
    auto found = store->find(id);
    if (!found) return found.error();
    if (!*found) return make_error(kind::unknown_job, "no job with id \"" + id + "\"", "id");
    return store->events(id, limit);
}

template <typename T, typename Read>
void job_history::read_on_reader(job_handler<T> h, Read read) {
    auto shared_h = std::make_shared<job_handler<T>>(std::move(h));
    const bool queued = reader_.post([self = shared_from_this(), shared_h, read = std::move(read)]() mutable {
        operation_result<T> result = read(*self);
        auto executor = self->executor_;
        // The last reference may go with this handler: never on the reader thread, which its owner joins.
        net::post(executor, [self = std::move(self), shared_h, result = std::move(result)]() mutable {
            net::post(self->executor_, net::append(std::move(*shared_h), std::move(result)));
        });
    });
    if (!queued)
        net::post(executor_,
                  net::append(std::move(*shared_h),
                              operation_result<T>(make_error(
                                  kind::queue_full,
                                  "too many reads of the job history waiting: ask again shortly"))));
}

void job_history::async_get(std::string id, job_handler<job_record> h) {
    read_on_reader<job_record>(std::move(h),
                               [id = std::move(id)](const job_history& j) { return j.get(id); });
}

void job_history::async_list(job_filter f, job_handler<job_page> h) {
    read_on_reader<job_page>(std::move(h), [f = std::move(f)](const job_history& j) { return j.list(f); });
}

void job_history::async_events(std::string id, std::size_t limit, job_handler<std::vector<json>> h) {
    read_on_reader<std::vector<json>>(
        std::move(h), [id = std::move(id), limit](const job_history& j) { return j.events(id, limit); });
}

}  // namespace gw::jobs
