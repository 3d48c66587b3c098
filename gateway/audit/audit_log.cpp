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
    const std::string& directory, std::shared_ptr<spdlog::logger> log) {
    auto store = audit_store::open(directory);
    if (!store) return store.error();
    return std::unique_ptr<audit_log>(new audit_log(std::move(*store), std::move(log)));
}

audit_log::audit_log(std::unique_ptr<audit_store> store, std::shared_ptr<spdlog::logger> log)
    : store_(std::move(store)), log_(std::move(log)), writer_([this] { run(); }) {}

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

void audit_log::run() {
    std::vector<audit_entry> batch;
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
            wake_.wait(lock, [&] { return stopping_ || !waiting_.empty(); });
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
    }
}

}  // namespace gw::audit
