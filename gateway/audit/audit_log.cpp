#include "gateway/audit/audit_log.hpp"

#include <chrono>
#include <vector>

#include <spdlog/spdlog.h>

#include "gateway/audit/audit_store.hpp"
#include "gateway/common/timestamp.hpp"

namespace gw::audit {

namespace {

// Queries waiting at most: each holds a caller's connection anyway, so the bound is generous.
constexpr std::size_t max_queries_waiting = 256;

}  // namespace

boost::system::result<std::unique_ptr<audit_log>, std::string> audit_log::open(
    const std::string& directory, std::shared_ptr<spdlog::logger> log, history_retention retention) {
    auto store = audit_store::open(directory);
    if (!store) return store.error();
    return std::unique_ptr<audit_log>(new audit_log(std::move(*store), std::move(log), retention));
}

audit_log::audit_log(std::unique_ptr<audit_store> store, std::shared_ptr<spdlog::logger> log,
                     history_retention retention)
    : store_(std::move(store)), log_(std::move(log)), retention_(retention), writer_([this] { run(); }) {}

audit_log::~audit_log() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    wake_.notify_one();
    writer_.join();
}

void audit_log::record(audit_entry entry) {
    {
        std::lock_guard lock(mutex_);
        if (entries_waiting_ >= max_waiting) {
            ++lost_;
            const auto now = epoch_ms(std::chrono::system_clock::now());
            if (log_ && now - last_loss_logged_ms_ >= 1000) {
                last_loss_logged_ms_ = now;
                log_->warn("audit: {} entries not recorded so far: the writer is {} entries behind", lost_,
                           entries_waiting_);
            }
            return;
        }
        ++entries_waiting_;
        waiting_.emplace_back(std::move(entry));
    }
    wake_.notify_one();
}

void audit_log::async_query(audit_filter filter, query_handler done) {
    {
        std::lock_guard lock(mutex_);
        if (waiting_.size() - entries_waiting_ < max_queries_waiting) {
            waiting_.emplace_back(query_request{std::move(filter), std::move(done)});
            wake_.notify_one();
            return;
        }
    }
    done(boost::system::result<audit_page, std::string>(boost::system::in_place_error,
                                                        "too many audit queries waiting"));
}

std::uint64_t audit_log::lost() const {
    std::lock_guard lock(mutex_);
    return lost_;
}

bool audit_log::sweep_batch() {
    std::optional<std::int64_t> before_ms;
    if (retention_.max_age) before_ms = epoch_ms(std::chrono::system_clock::now() - *retention_.max_age);
    auto deleted = store_->delete_old(before_ms, retention_.max_audit_entries, retention_batch);
    if (!deleted && log_)
        log_->warn("storage.retention: cannot delete old audit entries: {}", deleted.error());
    const std::size_t n = deleted ? *deleted : 0;
    swept_ += n;
    if (n == retention_batch) return true;
    if (swept_ > 0 && log_) log_->info("storage.retention: deleted {} audit entries", swept_);
    swept_ = 0;
    return false;
}

void audit_log::run() {
    std::vector<audit_entry> batch;
    const bool retains = !retention_.keeps_all_audit();
    bool sweeping = retains;  // a sweep at start
    auto next_sweep = std::chrono::steady_clock::now();
    // One transaction for what has gathered; a store that refuses it loses those entries (logged).
    auto write_batch = [&] {
        if (auto r = store_->append(batch); !r && log_)
            log_->error("audit: {} entries lost: {}", batch.size(), r.error());
        batch.clear();
    };
    while (true) {
        std::deque<work> taken;
        {
            std::unique_lock lock(mutex_);
            const auto ready = [&] { return stopping_ || !waiting_.empty(); };
            // While a sweep is in progress, one batch per turn: no waiting between them.
            if (!retains)
                wake_.wait(lock, ready);
            else if (!sweeping)
                wake_.wait_until(lock, next_sweep, ready);
            if (retains && !sweeping && std::chrono::steady_clock::now() >= next_sweep) sweeping = true;
            if (waiting_.empty() && stopping_) return;
            taken.swap(waiting_);
            entries_waiting_ = 0;
        }
        // Entries in order, each query after the entries recorded before it.
        for (auto& w : taken) {
            if (auto* e = std::get_if<audit_entry>(&w)) {
                batch.push_back(std::move(*e));
                continue;
            }
            write_batch();
            auto& q = std::get<query_request>(w);
            q.done(store_->query(q.filter));
        }
        write_batch();
        if (sweeping && !sweep_batch()) {
            sweeping = false;
            next_sweep = std::chrono::steady_clock::now() + retention_.sweep_interval;
        }
    }
}

}  // namespace gw::audit
