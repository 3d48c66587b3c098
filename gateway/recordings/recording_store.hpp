#pragma once
// Recordings on disk: <storage>/recordings.sqlite3, a file of its own (frames arrive by the thousand a
// second and must neither wait for nor fill the job store). Not thread-safe: the recording_writer owns
// it and uses it from its own thread only.
//
// Frames are appended in batches, each in one transaction with the recording's counters, so that after
// a crash the counters match the frames on disk. Commits are synchronous (FULL): the recorder commits
// once per flush interval, all recordings together, so a crash loses at most that interval.

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <boost/system/result.hpp>

#include "gateway/recordings/recording.hpp"

struct sqlite3;

namespace gw::recordings {

template <typename T>
using store_result = boost::system::result<T, std::string>;

struct recording_filter {
    std::optional<std::string> controller;
    std::optional<recording_state> state;
    std::optional<std::int64_t> since_ms;  // started at or after (milliseconds since the epoch)
    std::optional<std::int64_t> until_ms;  // started before
    std::optional<std::string> job;        // made by this job's runs
    std::size_t limit = 100;
};

// A recording's new rows with its record as after them (its counters count them).
struct row_batch {
    recording_record record;
    std::vector<recorded_frame> rows;
};

// One page of a recording's rows, in order; `next` is where the next page starts (nullopt: none left).
struct frame_page {
    std::vector<recorded_frame> rows;
    std::optional<std::int64_t> next;
};

class recording_store {
  public:
    // Creates the directory and the file if needed; the error names the file. `max_mb`: the file's
    // bound (0: none); a write beyond it fails as a full disk does, with a message that says so.
    static store_result<std::unique_ptr<recording_store>> open(const std::string& directory,
                                                               std::size_t max_mb = 0);
    ~recording_store();
    recording_store(const recording_store&) = delete;
    recording_store& operator=(const recording_store&) = delete;

    store_result<void> create(const recording_record& r);
    // The record's state, reason, end, axes and counters.
    store_result<void> update(const recording_record& r);
    // `rows` and the record's counters (r.frames, r.losses, r.axes: as after these rows), in one
    // transaction.
    store_result<void> append(const recording_record& r, std::span<const recorded_frame> rows);
    // Several recordings' rows and counters in one transaction: one commit (one disk flush) for all.
    store_result<void> append_all(std::span<const row_batch> batches);
    // The last append failed for want of room: the disk, or the bound given to open().
    bool last_write_was_full() const { return last_write_full_; }

    store_result<std::optional<recording_record>> get(const std::string& id) const;
    // Newest first.
    store_result<std::vector<recording_record>> list(const recording_filter& f) const;
    // The recording and its rows; false when there was none.
    store_result<bool> remove(const std::string& id);
    // Up to `limit` rows from row number `from` (0: the first).
    store_result<frame_page> rows(const std::string& id, std::int64_t from, std::size_t limit) const;

  private:
    recording_store(sqlite3* db, std::string path) : db_(db), path_(std::move(path)) {}
    store_result<void> exec(const char* sql);
    // A PRAGMA's number (0 when it cannot be read).
    std::int64_t pragma_number(const char* sql) const;
    // Inside a transaction (the caller rolls back on an error).
    store_result<void> insert_rows(const recording_record& r, std::span<const recorded_frame> rows);
    sqlite3* db_;
    std::string path_;
    bool last_write_full_ = false;
};

}  // namespace gw::recordings
