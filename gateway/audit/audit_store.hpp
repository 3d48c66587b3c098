#pragma once
// The audit trail on disk: <storage>/audit.sqlite3, one table, appended in batches. Not thread-safe:
// audit_log owns it and uses it from its own thread only. A file of its own, so that the trail
// neither waits for nor fills the job store.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <boost/system/result.hpp>

#include "gateway/audit/audit_entry.hpp"

struct sqlite3;

namespace gw::audit {

class audit_store {
  public:
    // Creates the directory and the file if needed; the error names the file.
    static boost::system::result<std::unique_ptr<audit_store>, std::string> open(
        const std::string& directory);
    ~audit_store();
    audit_store(const audit_store&) = delete;
    audit_store& operator=(const audit_store&) = delete;

    // In one transaction; the entries' ids are set. The error says why nothing was written.
    boost::system::result<void, std::string> append(std::vector<audit_entry>& entries);
    // Deletes up to `batch` entries in one transaction, oldest first: those recorded before
    // `before_ms` (epoch ms) and those beyond the newest `keep_newest`. How many were deleted (fewer
    // than `batch`: none are left).
    boost::system::result<std::size_t, std::string> delete_old(std::optional<std::int64_t> before_ms,
                                                               std::optional<std::size_t> keep_newest,
                                                               std::size_t batch);
    // Newest first; limit outside 1..500 is clamped by the caller (api/).
    boost::system::result<audit_page, std::string> query(const audit_filter& filter) const;

  private:
    audit_store(sqlite3* db, std::string path) : db_(db), path_(std::move(path)) {}
    sqlite3* db_;
    std::string path_;
};

}  // namespace gw::audit
