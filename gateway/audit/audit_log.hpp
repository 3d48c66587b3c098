#pragma once
// The audit trail's writer: record() from any thread costs a copy into a bounded queue; the log's
// own thread appends what waits in one transaction at a time (so no transport waits for the disk),
// and answers queries there too. At max_waiting entries waiting, more are counted as lost and
// logged (at most once a second): the trail never holds up a HALT or a move.

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <variant>

#include <boost/system/result.hpp>

#include "gateway/audit/audit_entry.hpp"
#include "gateway/common/history_retention.hpp"

namespace spdlog {
class logger;
}

namespace gw::audit {

class audit_store;

class audit_log {
  public:
    static constexpr std::size_t max_waiting = 10000;
    using query_handler = std::function<void(boost::system::result<audit_page, std::string>)>;

    // Opens <directory>/audit.sqlite3 and starts the writer; the error names the file.
    // `retention`: storage.retention, swept on the writer's thread at start and every sweep_interval,
    // one small transaction between the writes.
    static boost::system::result<std::unique_ptr<audit_log>, std::string> open(
        const std::string& directory, std::shared_ptr<spdlog::logger> log, history_retention retention = {});
    ~audit_log();  // writes what waits, then stops
    audit_log(const audit_log&) = delete;
    audit_log& operator=(const audit_log&) = delete;

    void record(audit_entry entry);
    // Runs on the writer's thread, after every entry recorded before it is written; `done` is called
    // there (post it on to where it belongs).
    void async_query(audit_filter filter, query_handler done);

    std::uint64_t lost() const;

  private:
    struct query_request {
        audit_filter filter;
        query_handler done;
    };
    using work = std::variant<audit_entry, query_request>;

    audit_log(std::unique_ptr<audit_store> store, std::shared_ptr<spdlog::logger> log,
              history_retention retention);
    void run();
    // One batch of storage.retention's deletions; false when none are left.
    bool sweep_batch();

    std::unique_ptr<audit_store> store_;
    std::shared_ptr<spdlog::logger> log_;
    const history_retention retention_;
    std::size_t swept_ = 0;  // entries deleted by the sweep in progress (writer thread)
    mutable std::mutex mutex_;
    std::condition_variable wake_;
    std::deque<work> waiting_;
    std::size_t entries_waiting_ = 0;
    std::uint64_t lost_ = 0;
    std::int64_t last_loss_logged_ms_ = 0;
    bool stopping_ = false;
    std::thread writer_;
};

}  // namespace gw::audit
