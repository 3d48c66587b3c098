#include "gateway/recordings/recording_store.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <sqlite3.h>

#include "gateway/storage/sqlite_file.hpp"

namespace gw::recordings {

namespace {

// The layout: a recording's rows are clustered under its integer key in the order they came (seq), so
// a row costs its values and a few bytes of key, and a page of rows is one range of the table.
constexpr int layout_version = 3;
constexpr const char* schema = R"sql(
CREATE TABLE IF NOT EXISTS recordings (
  key INTEGER PRIMARY KEY,
  id TEXT NOT NULL UNIQUE,
  controller TEXT NOT NULL,
  name TEXT NOT NULL,
  state TEXT NOT NULL,
  reason TEXT NOT NULL,
  started_ms INTEGER NOT NULL,
  stopped_ms INTEGER,
  frames INTEGER NOT NULL,
  losses INTEGER NOT NULL,
  axes TEXT NOT NULL,
  ttl_in_mode INTEGER NOT NULL,
  previous_in_mode INTEGER,
  max_frames INTEGER,
  max_s REAL,
  metadata TEXT NOT NULL,
  job TEXT);
CREATE INDEX IF NOT EXISTS recordings_controller ON recordings(controller, started_ms);
CREATE INDEX IF NOT EXISTS recordings_job ON recordings(job);
CREATE TABLE IF NOT EXISTS frames (
  recording INTEGER NOT NULL,
  seq INTEGER NOT NULL,
  idx INTEGER NOT NULL,
  time_us INTEGER NOT NULL,
  loss INTEGER NOT NULL,
  counts BLOB NOT NULL,
  um BLOB NOT NULL,
  PRIMARY KEY (recording, seq)) WITHOUT ROWID;
PRAGMA user_version = 3;
)sql";

using sqlite::bind_text;
using sqlite::column_text;
using sqlite::error_of;
using sqlite::statement;

template <typename T>
void bind_optional(sqlite3_stmt* s, int index, const std::optional<T>& v) {
    if (!v)
        sqlite3_bind_null(s, index);
    else if constexpr (std::is_floating_point_v<T>)
        sqlite3_bind_double(s, index, *v);
    else
        sqlite3_bind_int64(s, index, static_cast<sqlite3_int64>(*v));
}

template <typename T>
std::optional<T> column_optional(sqlite3_stmt* s, int column) {
    if (sqlite3_column_type(s, column) == SQLITE_NULL) return std::nullopt;
    if constexpr (std::is_floating_point_v<T>)
        return sqlite3_column_double(s, column);
    else
        return static_cast<T>(sqlite3_column_int64(s, column));
}

// Little-endian bytes of 32-bit counts, and of doubles (NaN: unknown).
std::string counts_blob(const std::vector<std::int32_t>& counts) {
    std::string out;
    for (const auto c : counts) {
        const auto u = static_cast<std::uint32_t>(c);
        for (int shift = 0; shift < 32; shift += 8)
            out.push_back(static_cast<char>((u >> shift) & 0xff));
    }
    return out;
}

std::string um_blob(const std::vector<std::optional<double>>& um) {
    std::string out;
    for (const auto& v : um) {
        const double d = v.value_or(std::numeric_limits<double>::quiet_NaN());
        std::uint64_t u = 0;
        std::memcpy(&u, &d, sizeof u);
        for (int shift = 0; shift < 64; shift += 8)
            out.push_back(static_cast<char>((u >> shift) & 0xff));
    }
    return out;
}

std::vector<std::int32_t> counts_of(const unsigned char* bytes, std::size_t size) {
    std::vector<std::int32_t> out;
    for (std::size_t i = 0; i + 4 <= size; i += 4) {
        std::uint32_t u = 0;
        for (int k = 3; k >= 0; --k)
            u = (u << 8) | bytes[i + static_cast<std::size_t>(k)];
        out.push_back(static_cast<std::int32_t>(u));
    }
    return out;
}

std::vector<std::optional<double>> um_of(const unsigned char* bytes, std::size_t size) {
    std::vector<std::optional<double>> out;
    for (std::size_t i = 0; i + 8 <= size; i += 8) {
        std::uint64_t u = 0;
        for (int k = 7; k >= 0; --k)
            u = (u << 8) | bytes[i + static_cast<std::size_t>(k)];
        double d = 0;
        std::memcpy(&d, &u, sizeof d);
        out.push_back(std::isnan(d) ? std::nullopt : std::optional(d));
    }
    return out;
}

constexpr const char* record_columns =
    "id, controller, name, state, reason, started_ms, stopped_ms, frames, losses, axes, ttl_in_mode, "
    "previous_in_mode, max_frames, max_s, metadata, job";

recording_record record_of(sqlite3_stmt* s) {
    recording_record r;
    r.id = column_text(s, 0);
    r.controller = column_text(s, 1);
    r.name = column_text(s, 2);
    r.state = parse_recording_state(column_text(s, 3)).value_or(recording_state::failed);
    r.reason = column_text(s, 4);
    r.started_ms = sqlite3_column_int64(s, 5);
    r.stopped_ms = column_optional<std::int64_t>(s, 6);
    r.frames = static_cast<std::uint64_t>(sqlite3_column_int64(s, 7));
    r.losses = static_cast<std::uint64_t>(sqlite3_column_int64(s, 8));
    r.axes = column_text(s, 9);
    r.ttl_in_mode = sqlite3_column_int(s, 10);
    r.previous_in_mode = column_optional<int>(s, 11);
    r.max_frames = column_optional<std::uint64_t>(s, 12);
    r.max_s = column_optional<double>(s, 13);
    r.metadata = nlohmann::json::parse(column_text(s, 14), nullptr, false);
    if (r.metadata.is_discarded()) r.metadata = nlohmann::json::object();
    if (sqlite3_column_type(s, 15) != SQLITE_NULL) r.job = column_text(s, 15);
    return r;
}

}  // namespace

store_result<std::unique_ptr<recording_store>> recording_store::open(const std::string& directory,
                                                                     std::size_t max_mb) {
    using result = store_result<std::unique_ptr<recording_store>>;
    // A file of the first layout (never released: the recorder was not reachable from outside) is
    // replaced; the second gains the column of the job that made a recording.
    auto file = sqlite::open_file(directory, "recordings.sqlite3", "SELECT 1", "cannot open the recordings");
    if (!file) return result(boost::system::in_place_error, file.error());
    std::unique_ptr<recording_store> store(new recording_store(file->db, file->path));
    const auto found = store->pragma_number("PRAGMA user_version");
    if (found == 2)
        if (auto added = store->exec("ALTER TABLE recordings ADD COLUMN job TEXT"); !added)
            return result(boost::system::in_place_error, added.error());
    if (found != layout_version && found != 2)
        if (auto dropped = store->exec("DROP TABLE IF EXISTS frames; DROP TABLE IF EXISTS recordings;");
            !dropped)
            return result(boost::system::in_place_error, dropped.error());
    if (auto made = store->exec(schema); !made) return result(boost::system::in_place_error, made.error());
    // Each commit (one per flush interval) reaches the disk before the next: a crash, even of the
    // machine, loses at most the rows of one interval.
    if (auto full = store->exec("PRAGMA synchronous = FULL"); !full)
        return result(boost::system::in_place_error, full.error());
    if (max_mb > 0) {
        // The page count the bound allows (PRAGMA takes no parameters: a number computed here).
        const auto page_size = std::max<std::int64_t>(512, store->pragma_number("PRAGMA page_size"));
        const auto pages = std::max<std::uint64_t>(
            1, std::uint64_t{max_mb} * 1024 * 1024 / static_cast<std::uint64_t>(page_size));
        const auto sql = "PRAGMA max_page_count = " + std::to_string(pages);
        if (auto bounded = store->exec(sql.c_str()); !bounded)
            return result(boost::system::in_place_error, bounded.error());
    }
    return store;
}

recording_store::~recording_store() {
    sqlite3_close(db_);
}

std::int64_t recording_store::pragma_number(const char* sql) const {
    statement q;
    if (sqlite3_prepare_v2(db_, sql, -1, &q.s, nullptr) != SQLITE_OK || sqlite3_step(q.s) != SQLITE_ROW)
        return 0;
    return sqlite3_column_int64(q.s, 0);
}

store_result<void> recording_store::exec(const char* sql) {
    if (sqlite3_exec(db_, sql, nullptr, nullptr, nullptr) != SQLITE_OK)
        return store_result<void>(boost::system::in_place_error, error_of(db_, path_, sql));
    return {};
}

store_result<void> recording_store::create(const recording_record& r) {
    statement q;
    const std::string sql =
        std::string("INSERT INTO recordings (") + record_columns +
        ") VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16)";
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &q.s, nullptr) != SQLITE_OK)
        return store_result<void>(boost::system::in_place_error,
                                  error_of(db_, path_, "cannot add a recording"));
    bind_text(q.s, 1, r.id);
    bind_text(q.s, 2, r.controller);
    bind_text(q.s, 3, r.name);
    bind_text(q.s, 4, std::string(to_string(r.state)));
    bind_text(q.s, 5, r.reason);
    sqlite3_bind_int64(q.s, 6, r.started_ms);
    bind_optional(q.s, 7, r.stopped_ms);
    sqlite3_bind_int64(q.s, 8, static_cast<sqlite3_int64>(r.frames));
    sqlite3_bind_int64(q.s, 9, static_cast<sqlite3_int64>(r.losses));
    bind_text(q.s, 10, r.axes);
    sqlite3_bind_int(q.s, 11, r.ttl_in_mode);
    bind_optional(q.s, 12, r.previous_in_mode);
    bind_optional(q.s, 13, r.max_frames);
    bind_optional(q.s, 14, r.max_s);
    bind_text(q.s, 15, r.metadata.dump());
    if (r.job) bind_text(q.s, 16, *r.job);
    if (sqlite3_step(q.s) != SQLITE_DONE)
        return store_result<void>(boost::system::in_place_error,
                                  error_of(db_, path_, "cannot add a recording"));
    return {};
}

store_result<void> recording_store::update(const recording_record& r) {
    statement q;
    const char* sql =
        "UPDATE recordings SET state = ?2, reason = ?3, stopped_ms = ?4, frames = ?5, losses = ?6, axes = "
        "?7, "
        "previous_in_mode = ?8 WHERE id = ?1";
    if (sqlite3_prepare_v2(db_, sql, -1, &q.s, nullptr) != SQLITE_OK)
        return store_result<void>(boost::system::in_place_error,
                                  error_of(db_, path_, "cannot update a recording"));
    bind_text(q.s, 1, r.id);
    bind_text(q.s, 2, std::string(to_string(r.state)));
    bind_text(q.s, 3, r.reason);
    bind_optional(q.s, 4, r.stopped_ms);
    sqlite3_bind_int64(q.s, 5, static_cast<sqlite3_int64>(r.frames));
    sqlite3_bind_int64(q.s, 6, static_cast<sqlite3_int64>(r.losses));
    bind_text(q.s, 7, r.axes);
    bind_optional(q.s, 8, r.previous_in_mode);
    if (sqlite3_step(q.s) != SQLITE_DONE)
        return store_result<void>(boost::system::in_place_error,
                                  error_of(db_, path_, "cannot update a recording"));
    return {};
}

store_result<void> recording_store::insert_rows(const recording_record& r,
                                                std::span<const recorded_frame> rows) {
    // The error as the failing call left it: finalizing the statements after it would reset it.
    const auto failed = [&] {
        last_write_full_ = sqlite3_errcode(db_) == SQLITE_FULL;
        return store_result<void>(
            boost::system::in_place_error,
            last_write_full_
                ? path_ + ": full: the disk, or storage.recordings_max_mb (delete recordings to make room)"
                : error_of(db_, path_, "cannot store frames"));
    };
    statement key_of;
    if (sqlite3_prepare_v2(db_, "SELECT key FROM recordings WHERE id = ?1", -1, &key_of.s, nullptr) !=
        SQLITE_OK)
        return failed();
    bind_text(key_of.s, 1, r.id);
    if (sqlite3_step(key_of.s) != SQLITE_ROW)
        return store_result<void>(boost::system::in_place_error,
                                  path_ + ": no recording " + r.id + " to store frames of");
    const auto key = sqlite3_column_int64(key_of.s, 0);
    statement q;
    const char* sql =
        "INSERT INTO frames (recording, seq, idx, time_us, loss, counts, um) VALUES (?1, ?2, ?3, ?4, ?5, ?6, "
        "?7)";
    if (sqlite3_prepare_v2(db_, sql, -1, &q.s, nullptr) != SQLITE_OK) return failed();
    // The record's counters are as after these rows: the first of them is row number total - size.
    auto seq = static_cast<sqlite3_int64>(r.frames + r.losses - rows.size());
    for (const auto& f : rows) {
        sqlite3_bind_int64(q.s, 1, key);
        sqlite3_bind_int64(q.s, 2, seq++);
        sqlite3_bind_int64(q.s, 3, static_cast<sqlite3_int64>(f.index));
        sqlite3_bind_int64(q.s, 4, f.time_us);
        sqlite3_bind_int(q.s, 5, static_cast<int>(f.loss));
        const auto counts = counts_blob(f.counts);
        const auto um = um_blob(f.um);
        sqlite3_bind_blob(q.s, 6, counts.data(), static_cast<int>(counts.size()), SQLITE_TRANSIENT);
        sqlite3_bind_blob(q.s, 7, um.data(), static_cast<int>(um.size()), SQLITE_TRANSIENT);
        if (sqlite3_step(q.s) != SQLITE_DONE) return failed();
        sqlite3_reset(q.s);
    }
    if (auto updated = update(r); !updated) {
        // Its statement is finalized by now: SQLite's message says what the code would have.
        last_write_full_ = updated.error().find("database or disk is full") != std::string::npos;
        return updated;
    }
    return {};
}

store_result<void> recording_store::append(const recording_record& r, std::span<const recorded_frame> rows) {
    const row_batch one{r, {rows.begin(), rows.end()}};
    return append_all(std::span<const row_batch>(&one, 1));
}

store_result<void> recording_store::append_all(std::span<const row_batch> batches) {
    last_write_full_ = false;
    if (auto begun = exec("BEGIN IMMEDIATE"); !begun) return begun;
    for (const auto& b : batches) {
        auto inserted = insert_rows(b.record, b.rows);
        if (inserted) continue;
        (void)exec("ROLLBACK");
        return inserted;
    }
    auto committed = exec("COMMIT");
    if (!committed) {
        last_write_full_ = sqlite3_errcode(db_) == SQLITE_FULL;
        (void)exec("ROLLBACK");
    }
    return committed;
}

store_result<std::optional<recording_record>> recording_store::get(const std::string& id) const {
    using result = store_result<std::optional<recording_record>>;
    statement q;
    const std::string sql = std::string("SELECT ") + record_columns + " FROM recordings WHERE id = ?1";
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &q.s, nullptr) != SQLITE_OK)
        return result(boost::system::in_place_error, error_of(db_, path_, "cannot read a recording"));
    bind_text(q.s, 1, id);
    const int rc = sqlite3_step(q.s);
    if (rc == SQLITE_DONE) return std::optional<recording_record>();
    if (rc != SQLITE_ROW)
        return result(boost::system::in_place_error, error_of(db_, path_, "cannot read a recording"));
    return std::optional(record_of(q.s));
}

store_result<std::vector<recording_record>> recording_store::list(const recording_filter& f) const {
    using result = store_result<std::vector<recording_record>>;
    statement q;
    const std::string sql =
        std::string("SELECT ") + record_columns +
        " FROM recordings WHERE (?1 IS NULL OR controller = ?1) AND (?2 IS NULL OR state = ?2)"
        " AND (?4 IS NULL OR started_ms >= ?4) AND (?5 IS NULL OR started_ms < ?5) AND (?6 IS NULL OR job = "
        "?6)"
        " ORDER BY started_ms DESC, id DESC LIMIT ?3";
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &q.s, nullptr) != SQLITE_OK)
        return result(boost::system::in_place_error, error_of(db_, path_, "cannot list recordings"));
    if (f.controller) bind_text(q.s, 1, *f.controller);
    if (f.state) bind_text(q.s, 2, std::string(to_string(*f.state)));
    sqlite3_bind_int64(q.s, 3, static_cast<sqlite3_int64>(f.limit));
    if (f.since_ms) sqlite3_bind_int64(q.s, 4, *f.since_ms);
    if (f.until_ms) sqlite3_bind_int64(q.s, 5, *f.until_ms);
    if (f.job) bind_text(q.s, 6, *f.job);
    std::vector<recording_record> out;
    int rc = SQLITE_ROW;
    while ((rc = sqlite3_step(q.s)) == SQLITE_ROW)
        out.push_back(record_of(q.s));
    if (rc != SQLITE_DONE)
        return result(boost::system::in_place_error, error_of(db_, path_, "cannot list recordings"));
    return out;
}

store_result<bool> recording_store::remove(const std::string& id) {
    using result = store_result<bool>;
    if (auto begun = exec("BEGIN IMMEDIATE"); !begun)
        return result(boost::system::in_place_error, begun.error());
    bool ok = true;
    bool found = false;
    for (const char* sql : {"DELETE FROM frames WHERE recording = (SELECT key FROM recordings WHERE id = ?1)",
                            "DELETE FROM recordings WHERE id = ?1"}) {
        statement q;
        ok = ok && sqlite3_prepare_v2(db_, sql, -1, &q.s, nullptr) == SQLITE_OK;
        if (!ok) break;
        bind_text(q.s, 1, id);
        ok = sqlite3_step(q.s) == SQLITE_DONE;
        found = sqlite3_changes(db_) > 0;  // the last statement's: the recording itself
    }
    if (!ok) {
        auto why = error_of(db_, path_, "cannot delete a recording");
        (void)exec("ROLLBACK");
        return result(boost::system::in_place_error, std::move(why));
    }
    if (auto committed = exec("COMMIT"); !committed)
        return result(boost::system::in_place_error, committed.error());
    return found;
}

store_result<frame_page> recording_store::rows(const std::string& id, std::int64_t from,
                                               std::size_t limit) const {
    using result = store_result<frame_page>;
    statement q;
    const char* sql =
        "SELECT seq, idx, time_us, loss, counts, um FROM frames WHERE recording = (SELECT key FROM "
        "recordings "
        "WHERE id = ?1) AND seq >= ?2 ORDER BY seq LIMIT ?3";
    if (sqlite3_prepare_v2(db_, sql, -1, &q.s, nullptr) != SQLITE_OK)
        return result(boost::system::in_place_error, error_of(db_, path_, "cannot read frames"));
    bind_text(q.s, 1, id);
    sqlite3_bind_int64(q.s, 2, from);
    sqlite3_bind_int64(q.s, 3, static_cast<sqlite3_int64>(limit) + 1);  // one more: is there a next page?
    frame_page page;
    int rc = SQLITE_ROW;
    while ((rc = sqlite3_step(q.s)) == SQLITE_ROW) {
        if (page.rows.size() == limit) {
            page.next = sqlite3_column_int64(q.s, 0);
            break;
        }
        recorded_frame f;
        f.index = static_cast<std::uint64_t>(sqlite3_column_int64(q.s, 1));
        f.time_us = sqlite3_column_int64(q.s, 2);
        // Bytes from the file are data: a value no writer makes reads as a loss, never as a frame.
        const int loss = sqlite3_column_int(q.s, 3);
        f.loss = loss >= 0 && loss <= static_cast<int>(loss_kind::overrun) ? static_cast<loss_kind>(loss)
                                                                           : loss_kind::garbled;
        f.counts = counts_of(static_cast<const unsigned char*>(sqlite3_column_blob(q.s, 4)),
                             static_cast<std::size_t>(sqlite3_column_bytes(q.s, 4)));
        f.um = um_of(static_cast<const unsigned char*>(sqlite3_column_blob(q.s, 5)),
                     static_cast<std::size_t>(sqlite3_column_bytes(q.s, 5)));
        page.rows.push_back(std::move(f));
    }
    if (rc != SQLITE_ROW && rc != SQLITE_DONE)
        return result(boost::system::in_place_error, error_of(db_, path_, "cannot read frames"));
    return page;
}

}  // namespace gw::recordings
