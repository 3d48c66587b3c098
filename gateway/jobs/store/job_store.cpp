#include "gateway/jobs/store/job_store.hpp"

#include <algorithm>
#include <filesystem>
#include <fmt/format.h>
#include <limits>
#include <sqlite3.h>
#include <string_view>
#include <system_error>
#include <utility>

#include "gateway/common/timestamp.hpp"
#include "gateway/jobs/job_json.hpp"

namespace gw::jobs {

namespace {

// Schema version 1. Times are epoch milliseconds (UTC). Ids are time-ordered, so "newest first" is
// "descending id" and every listing index ends in id.
constexpr const char* schema_v1 = R"sql(
CREATE TABLE jobs (
    id              TEXT PRIMARY KEY,
    controller      TEXT NOT NULL,
    type            TEXT NOT NULL,
    state           TEXT NOT NULL,
    spec            TEXT NOT NULL,
    steps_done      INTEGER NOT NULL,
    steps_total     INTEGER NOT NULL,
    current_step    TEXT NOT NULL,
    remaining_s     REAL,
    estimated_s     REAL NOT NULL,
    plan_path       TEXT NOT NULL,
    idempotency_key TEXT,
    submitted_by    TEXT NOT NULL,
    request_id      TEXT NOT NULL,
    reason          TEXT NOT NULL,
    created_ms      INTEGER NOT NULL,
    started_ms      INTEGER,
    finished_ms     INTEGER,
    updated_ms      INTEGER NOT NULL
);
CREATE UNIQUE INDEX jobs_idempotency_key ON jobs(idempotency_key) WHERE idempotency_key IS NOT NULL;
CREATE INDEX jobs_controller ON jobs(controller, id);
CREATE INDEX jobs_type ON jobs(type, id);
CREATE INDEX jobs_state ON jobs(state, id);
CREATE TABLE job_transitions (
    seq        INTEGER PRIMARY KEY,
    job_id     TEXT NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,
    from_state TEXT,
    to_state   TEXT NOT NULL,
    reason     TEXT NOT NULL,
    at_ms      INTEGER NOT NULL
);
CREATE INDEX job_transitions_job ON job_transitions(job_id, seq);
CREATE TABLE job_events (
    job_id TEXT NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,
    seq    INTEGER NOT NULL,
    event  TEXT NOT NULL,
    at_ms  INTEGER NOT NULL,
    PRIMARY KEY (job_id, seq)
) WITHOUT ROWID;
PRAGMA user_version = 1;
)sql";

// Schema version 2: the commands that undo what a running job changed on its controller
// (job_context::restore_if_stopped), so that a gateway started after a crash can send them. A JSON
// array in registration order; no row when there is nothing to undo.
constexpr const char* migration_v2 = R"sql(
CREATE TABLE job_restore_commands (
    job_id     TEXT PRIMARY KEY REFERENCES jobs(id) ON DELETE CASCADE,
    commands   TEXT NOT NULL,
    updated_ms INTEGER NOT NULL
) WITHOUT ROWID;
PRAGMA user_version = 2;
)sql";

constexpr std::string_view job_columns =
    "id, controller, type, state, spec, steps_done, steps_total, current_step, remaining_s, "
    "estimated_s, plan_path, idempotency_key, submitted_by, request_id, reason, created_ms, "
    "started_ms, finished_ms, updated_ms";

constexpr std::size_t max_list_limit = 500;

operation_error storage_error(sqlite3* db, const std::string& path, std::string_view doing) {
    return make_error(
        operation_error_kind::storage_unavailable,
        fmt::format("job store {}: {}: {}", path, doing, db ? sqlite3_errmsg(db) : "out of memory"));
}

operation_error corrupt(const std::string& path, std::string_view what) {
    return make_error(operation_error_kind::storage_unavailable,
                      fmt::format("job store {}: corrupt row: {}", path, what));
}

std::string dump(const nlohmann::json& j) {
    return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

job_clock::time_point from_ms(std::int64_t ms) {
    return job_clock::time_point(std::chrono::milliseconds(ms));
}

std::int64_t to_int64(std::size_t v) {
    return v > static_cast<std::size_t>(std::numeric_limits<std::int64_t>::max())
               ? std::numeric_limits<std::int64_t>::max()
               : static_cast<std::int64_t>(v);
}

// A prepared statement; binding errors are kept and reported by step().
class statement {
  public:
    explicit statement(sqlite3_stmt* s) : stmt_(s) {}
    ~statement() { sqlite3_finalize(stmt_); }
    statement(const statement&) = delete;
    statement& operator=(const statement&) = delete;
    statement(statement&& o) noexcept : stmt_(std::exchange(o.stmt_, nullptr)), rc_(o.rc_) {}
    statement& operator=(statement&&) = delete;

    statement& text(int i, std::string_view v) {
        // data() of an empty view may be null, which SQLite would store as NULL.
        if (rc_ == SQLITE_OK)
            rc_ = sqlite3_bind_text64(stmt_, i, v.empty() ? "" : v.data(), v.size(), SQLITE_TRANSIENT,
                                      SQLITE_UTF8);
        return *this;
    }
    statement& text(const char* name, std::string_view v) { return text(index(name), v); }
    statement& integer(int i, std::int64_t v) {
        if (rc_ == SQLITE_OK) rc_ = sqlite3_bind_int64(stmt_, i, v);
        return *this;
    }
    statement& integer(const char* name, std::int64_t v) { return integer(index(name), v); }
    statement& real(int i, double v) {
        if (rc_ == SQLITE_OK) rc_ = sqlite3_bind_double(stmt_, i, v);
        return *this;
    }
    statement& null(int i) {
        if (rc_ == SQLITE_OK) rc_ = sqlite3_bind_null(stmt_, i);
        return *this;
    }
    statement& opt_text(int i, const std::optional<std::string>& v) { return v ? text(i, *v) : null(i); }
    statement& opt_real(int i, const std::optional<double>& v) { return v ? real(i, *v) : null(i); }
    statement& opt_time(int i, const std::optional<job_clock::time_point>& v) {
        return v ? integer(i, epoch_ms(*v)) : null(i);
    }

    // SQLITE_ROW, SQLITE_DONE or an error code.
    int step() { return rc_ == SQLITE_OK ? sqlite3_step(stmt_) : rc_; }

    bool is_null(int col) const { return sqlite3_column_type(stmt_, col) == SQLITE_NULL; }
    std::int64_t integer(int col) const { return sqlite3_column_int64(stmt_, col); }
    double real(int col) const { return sqlite3_column_double(stmt_, col); }
    std::string text(int col) const {
        auto p = sqlite3_column_text(stmt_, col);
        auto n = sqlite3_column_bytes(stmt_, col);
        return p ? std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(n)) : std::string();
    }

  private:
    int index(const char* name) {
        int i = sqlite3_bind_parameter_index(stmt_, name);
        if (i == 0 && rc_ == SQLITE_OK) rc_ = SQLITE_RANGE;
        return i;
    }

    sqlite3_stmt* stmt_;
    int rc_ = SQLITE_OK;
};

// One call's view of the connection: prepares statements, runs fixed SQL, names errors.
struct connection {
    sqlite3* db;
    const std::string& path;

    operation_error error(std::string_view doing) const { return storage_error(db, path, doing); }

    operation_result<statement> prepare(std::string_view sql) const {
        sqlite3_stmt* s = nullptr;
        if (sqlite3_prepare_v2(db, sql.data(), static_cast<int>(sql.size()), &s, nullptr) != SQLITE_OK) {
            sqlite3_finalize(s);
            return error("prepare");
        }
        return statement(s);
    }

    // Runs SQL without values (transaction control, schema).
    operation_result<void> exec(const char* sql, std::string_view doing) const {
        if (sqlite3_exec(db, sql, nullptr, nullptr, nullptr) != SQLITE_OK) return error(doing);
        return {};
    }
};

// BEGIN ... COMMIT; rolled back when it goes out of scope uncommitted.
class transaction {
  public:
    explicit transaction(const connection& c) : c_(c) {}
    ~transaction() {
        // A failed statement (disk full, I/O error) may already have rolled SQLite's transaction back.
        if (active_ && !sqlite3_get_autocommit(c_.db))
            sqlite3_exec(c_.db, "ROLLBACK", nullptr, nullptr, nullptr);
    }
    transaction(const transaction&) = delete;
    transaction& operator=(const transaction&) = delete;

    // Writers take the write lock at once so a busy file waits (busy_timeout) instead of failing midway.
    operation_result<void> begin(bool write) {
        auto r = c_.exec(write ? "BEGIN IMMEDIATE" : "BEGIN", "begin transaction");
        active_ = r.has_value();
        return r;
    }
    operation_result<void> commit() {
        auto r = c_.exec("COMMIT", "commit");
        if (r) active_ = false;
        return r;
    }

  private:
    const connection& c_;
    bool active_ = false;
};

// Columns in job_columns order.
operation_result<job_record> read_job(const statement& s, const std::string& path) {
    job_record j;
    j.id = s.text(0);
    j.controller = s.text(1);
    auto type = parse_job_type(s.text(2));
    if (!type) return corrupt(path, fmt::format("job {} has unknown type '{}'", j.id, s.text(2)));
    j.type = *type;
    auto state = parse_job_state(s.text(3));
    if (!state) return corrupt(path, fmt::format("job {} has unknown state '{}'", j.id, s.text(3)));
    j.state = *state;
    j.spec = nlohmann::json::parse(s.text(4), nullptr, false);
    if (j.spec.is_discarded()) return corrupt(path, fmt::format("job {} has a spec that is not JSON", j.id));
    j.progress.steps_done = static_cast<std::size_t>(std::max<std::int64_t>(0, s.integer(5)));
    j.progress.steps_total = static_cast<std::size_t>(std::max<std::int64_t>(0, s.integer(6)));
    j.progress.current_step = s.text(7);
    if (!s.is_null(8)) j.progress.remaining_s = s.real(8);
    j.estimated_s = s.real(9);
    j.plan_path = s.text(10);
    if (!s.is_null(11)) j.idempotency_key = s.text(11);
    j.submitted_by = s.text(12);
    j.request_id = s.text(13);
    j.reason = s.text(14);
    j.created = from_ms(s.integer(15));
    if (!s.is_null(16)) j.started = from_ms(s.integer(16));
    if (!s.is_null(17)) j.finished = from_ms(s.integer(17));
    j.updated = from_ms(s.integer(18));
    return j;
}

// Runs a SELECT of job_columns; collects every row.
operation_result<std::vector<job_record>> read_jobs(statement& s, const connection& c) {
    std::vector<job_record> jobs;
    for (;;) {
        int rc = s.step();
        if (rc == SQLITE_DONE) return jobs;
        if (rc != SQLITE_ROW) return c.error("read jobs");
        auto j = read_job(s, c.path);
        if (!j) return j.error();
        jobs.push_back(std::move(*j));
    }
}

// In the caller's transaction.
operation_result<std::optional<job_record>> find_one_in(const connection& c, std::string_view where,
                                                        std::string_view value) {
    auto s = c.prepare(fmt::format("SELECT {} FROM jobs WHERE {} = ?1", job_columns, where));
    if (!s) return s.error();
    s->text(1, value);
    auto jobs = read_jobs(*s, c);
    if (!jobs) return jobs.error();
    if (jobs->empty()) return std::optional<job_record>{};
    return std::optional<job_record>{std::move(jobs->front())};
}

operation_result<std::optional<job_record>> find_one(const connection& c, std::string_view where,
                                                     std::string_view value) {
    transaction tx(c);
    if (auto r = tx.begin(false); !r) return r.error();
    auto job = find_one_in(c, where, value);
    if (!job) return job.error();
    if (auto r = tx.commit(); !r) return r.error();
    return job;
}

operation_result<std::int64_t> pragma_integer(const connection& c, const char* sql, std::string_view doing) {
    auto s = c.prepare(sql);
    if (!s) return c.error(doing);
    if (s->step() != SQLITE_ROW) return c.error(doing);
    return s->integer(0);
}

operation_result<std::string> pragma_text(const connection& c, const char* sql, std::string_view doing) {
    auto s = c.prepare(sql);
    if (!s) return c.error(doing);
    if (s->step() != SQLITE_ROW) return c.error(doing);
    return s->text(0);
}

void set_busy_timeout(sqlite3* db, std::chrono::milliseconds busy_timeout) {
    auto timeout = busy_timeout.count();
    sqlite3_busy_timeout(db, timeout > std::numeric_limits<int>::max() ? std::numeric_limits<int>::max()
                                                                       : static_cast<int>(timeout));
}

operation_result<void> configure(const connection& c, const job_store_options& options) {
    sqlite3_extended_result_codes(c.db, 1);
    set_busy_timeout(c.db, options.busy_timeout);

    // The first read also proves the file is a SQLite database ("file is not a database").
    auto version = pragma_integer(c, "PRAGMA user_version", "read schema version");
    if (!version) return version.error();
    if (*version > job_store_schema_version || *version < 0)
        return make_error(operation_error_kind::storage_unavailable,
                          fmt::format("job store {}: schema version {} is not supported (this gateway "
                                      "knows version {}; was the file written by a newer gateway?)",
                                      c.path, *version, job_store_schema_version));

    auto mode = pragma_text(c, "PRAGMA journal_mode = WAL", "set WAL journal");
    if (!mode) return mode.error();
    if (*mode != "wal")
        return make_error(
            operation_error_kind::storage_unavailable,
            fmt::format("job store {}: cannot use a WAL journal (journal mode is '{}')", c.path, *mode));
    if (auto r = c.exec("PRAGMA synchronous = FULL", "set synchronous"); !r) return r.error();
    if (auto r = c.exec("PRAGMA foreign_keys = ON", "enable foreign keys"); !r) return r.error();

    if (options.max_size_mb > 0) {
        auto page_size = pragma_integer(c, "PRAGMA page_size", "read page size");
        if (!page_size) return page_size.error();
        auto bytes = static_cast<unsigned long long>(options.max_size_mb) * 1024ULL * 1024ULL;
        auto pages = std::max<unsigned long long>(
            1, bytes / static_cast<unsigned long long>(std::max<std::int64_t>(1, *page_size)));
        // PRAGMA takes no bound parameters; this is a number we computed, not outside text.
        auto sql = fmt::format("PRAGMA max_page_count = {}", pages);
        if (auto r = pragma_integer(c, sql.c_str(), "set max_page_count"); !r) return r.error();
    }

    if (*version < job_store_schema_version) {
        transaction tx(c);
        if (auto r = tx.begin(true); !r) return r.error();
        // Another process may have created or migrated it while we waited for the lock.
        auto again = pragma_integer(c, "PRAGMA user_version", "read schema version");
        if (!again) return again.error();
        if (*again == 0) {
            if (auto r = c.exec(schema_v1, "create schema"); !r) return r.error();
        }
        if (*again <= 1) {
            if (auto r = c.exec(migration_v2, "migrate schema to version 2"); !r) return r.error();
        }
        if (auto r = tx.commit(); !r) return r.error();
    }
    return {};
}

// The second connection, for reads: in WAL mode a reader sees every committed transaction and never
// waits for the writer's commit (its fsync), so a read from an I/O thread is not held up by a write
// in progress on the job manager's thread.
operation_result<sqlite3*> open_reader(const std::string& path, const job_store_options& options) {
    sqlite3* reader = nullptr;
    if (sqlite3_open_v2(path.c_str(), &reader, SQLITE_OPEN_READWRITE | SQLITE_OPEN_FULLMUTEX, nullptr) !=
        SQLITE_OK) {
        auto e = storage_error(reader, path, "open for reading");
        sqlite3_close_v2(reader);
        return e;
    }
    sqlite3_extended_result_codes(reader, 1);
    set_busy_timeout(reader, options.busy_timeout);
    if (auto r = connection{reader, path}.exec("PRAGMA query_only = ON", "make the reader read-only"); !r) {
        sqlite3_close_v2(reader);
        return r.error();
    }
    return reader;
}

bool is_constraint(sqlite3* db, int extended) {
    return sqlite3_extended_errcode(db) == extended;
}

// The fields of a job record that never change after the submission. A state event is stored without
// them (the jobs row has them) and read back with them: the history keeps what changed.
constexpr std::string_view fixed_record_fields[] = {"id",           "controller", "type",           "created",
                                                    "submitted_by", "request_id", "idempotency_key"};

// A state event as stored: its record without the fixed fields. Other events as they are.
std::string stored_event_text(const nlohmann::json& event) {
    const auto job = event.find("job");
    if (job == event.end() || !job->is_object() || event.value("type", "") != "state") return dump(event);
    nlohmann::json slim = nlohmann::json::object();
    for (const auto& [key, value] : event.items()) {
        if (key != "job") slim[key] = value;
    }
    auto& record = slim["job"] = nlohmann::json::object();
    for (const auto& [key, value] : job->items()) {
        if (std::find(std::begin(fixed_record_fields), std::end(fixed_record_fields), key) ==
            std::end(fixed_record_fields))
            record[key] = value;
    }
    return dump(slim);
}

// Appends an event numbered after the job's last one, in the caller's transaction.
operation_result<void> insert_event(const connection& c, const std::string& job_id,
                                    const nlohmann::json& event) {
    auto s = c.prepare(
        "INSERT INTO job_events (job_id, seq, event, at_ms) "
        "SELECT ?1, COALESCE(MAX(seq), 0) + 1, ?2, ?3 FROM job_events WHERE job_id = ?1");
    if (!s) return s.error();
    s->text(1, job_id).text(2, stored_event_text(event)).integer(3, epoch_ms(job_clock::now()));
    if (s->step() != SQLITE_DONE) {
        if (is_constraint(c.db, SQLITE_CONSTRAINT_FOREIGNKEY))
            return make_error(operation_error_kind::unknown_job, fmt::format("no job {}", job_id));
        return c.error(fmt::format("append event of job {}", job_id));
    }
    return {};
}

}  // namespace

job_store::job_store(sqlite3* db, sqlite3* reader, std::string path)
    : db_(db), reader_(reader), path_(std::move(path)) {}

job_store::~job_store() {
    sqlite3_close_v2(reader_);
    sqlite3_close_v2(db_);
}

operation_result<std::unique_ptr<job_store>> job_store::open(const std::string& directory,
                                                             const job_store_options& options) {
    if (directory.empty())
        return make_error(operation_error_kind::storage_unavailable, "job store: storage.path is empty");
    namespace fs = std::filesystem;
    std::error_code ec;
    fs::create_directories(directory, ec);
    if (ec || !fs::is_directory(directory, ec))
        return make_error(operation_error_kind::storage_unavailable,
                          fmt::format("job store: cannot create directory {}: {}", directory,
                                      ec ? ec.message() : std::string("not a directory")));
    auto path = (fs::path(directory) / job_store_file_name).string();

    sqlite3* db = nullptr;
    int rc = sqlite3_open_v2(path.c_str(), &db,
                             SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX, nullptr);
    if (rc != SQLITE_OK) {
        auto e = storage_error(db, path, "open");
        sqlite3_close_v2(db);
        return e;
    }
    if (auto r = configure(connection{db, path}, options); !r) {
        sqlite3_close_v2(db);
        return r.error();
    }
    auto reader = open_reader(path, options);
    if (!reader) {
        sqlite3_close_v2(db);
        return reader.error();
    }
    return std::unique_ptr<job_store>(new job_store(db, *reader, std::move(path)));
}

operation_result<void> job_store::insert(const job_record& job, const nlohmann::json& first_event) {
    std::lock_guard lock(mutex_);
    connection c{db_, path_};
    transaction tx(c);
    if (auto r = tx.begin(true); !r) return r.error();

    auto s = c.prepare(
        fmt::format("INSERT INTO jobs ({}) VALUES "
                    "(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19)",
                    job_columns));
    if (!s) return s.error();
    s->text(1, job.id)
        .text(2, job.controller)
        .text(3, to_string(job.type))
        .text(4, to_string(job.state))
        .text(5, dump(job.spec))
        .integer(6, to_int64(job.progress.steps_done))
        .integer(7, to_int64(job.progress.steps_total))
        .text(8, job.progress.current_step)
        .opt_real(9, job.progress.remaining_s)
        .real(10, job.estimated_s)
        .text(11, job.plan_path)
        .opt_text(12, job.idempotency_key)
        .text(13, job.submitted_by)
        .text(14, job.request_id)
        .text(15, job.reason)
        .integer(16, epoch_ms(job.created))
        .opt_time(17, job.started)
        .opt_time(18, job.finished)
        .integer(19, epoch_ms(job.updated));
    if (s->step() != SQLITE_DONE) {
        if (is_constraint(db_, SQLITE_CONSTRAINT_PRIMARYKEY))
            return make_error(operation_error_kind::invalid_state,
                              fmt::format("job {} already exists", job.id));
        if (is_constraint(db_, SQLITE_CONSTRAINT_UNIQUE))
            return make_error(operation_error_kind::invalid_state,
                              fmt::format("idempotency key '{}' is already used by another job",
                                          job.idempotency_key.value_or("")));
        return c.error(fmt::format("insert job {}", job.id));
    }

    auto t = c.prepare(
        "INSERT INTO job_transitions (job_id, from_state, to_state, reason, at_ms) "
        "VALUES (?1, NULL, ?2, ?3, ?4)");
    if (!t) return t.error();
    t->text(1, job.id).text(2, to_string(job.state)).text(3, job.reason).integer(4, epoch_ms(job.created));
    if (t->step() != SQLITE_DONE) return c.error(fmt::format("record transition of job {}", job.id));

    if (!first_event.is_null())
        if (auto r = insert_event(c, job.id, first_event); !r) return r.error();
    return tx.commit();
}

operation_result<void> job_store::save(const job_record& job, const nlohmann::json& event) {
    std::lock_guard lock(mutex_);
    connection c{db_, path_};
    transaction tx(c);
    if (auto r = tx.begin(true); !r) return r.error();

    auto q = c.prepare("SELECT state FROM jobs WHERE id = ?1");
    if (!q) return q.error();
    q->text(1, job.id);
    int rc = q->step();
    if (rc == SQLITE_DONE)
        return make_error(operation_error_kind::unknown_job, fmt::format("no job {}", job.id));
    if (rc != SQLITE_ROW) return c.error(fmt::format("read job {}", job.id));
    auto stored_state = q->text(0);

    auto u = c.prepare(
        "UPDATE jobs SET state = ?2, steps_done = ?3, steps_total = ?4, current_step = ?5, "
        "remaining_s = ?6, estimated_s = ?7, plan_path = ?8, reason = ?9, started_ms = ?10, "
        "finished_ms = ?11, updated_ms = ?12 WHERE id = ?1");
    if (!u) return u.error();
    u->text(1, job.id)
        .text(2, to_string(job.state))
        .integer(3, to_int64(job.progress.steps_done))
        .integer(4, to_int64(job.progress.steps_total))
        .text(5, job.progress.current_step)
        .opt_real(6, job.progress.remaining_s)
        .real(7, job.estimated_s)
        .text(8, job.plan_path)
        .text(9, job.reason)
        .opt_time(10, job.started)
        .opt_time(11, job.finished)
        .integer(12, epoch_ms(job.updated));
    if (u->step() != SQLITE_DONE) return c.error(fmt::format("save job {}", job.id));

    if (stored_state != to_string(job.state)) {
        auto t = c.prepare(
            "INSERT INTO job_transitions (job_id, from_state, to_state, reason, at_ms) "
            "VALUES (?1, ?2, ?3, ?4, ?5)");
        if (!t) return t.error();
        t->text(1, job.id)
            .text(2, stored_state)
            .text(3, to_string(job.state))
            .text(4, job.reason)
            .integer(5, epoch_ms(job.updated));
        if (t->step() != SQLITE_DONE) return c.error(fmt::format("record transition of job {}", job.id));
    }
    if (!event.is_null())
        if (auto r = insert_event(c, job.id, event); !r) return r.error();
    return tx.commit();
}

operation_result<void> job_store::append_event(const std::string& job_id, const nlohmann::json& event) {
    std::lock_guard lock(mutex_);
    connection c{db_, path_};
    transaction tx(c);
    if (auto r = tx.begin(true); !r) return r.error();
    if (auto r = insert_event(c, job_id, event); !r) return r.error();
    return tx.commit();
}

operation_result<std::size_t> job_store::delete_ended(std::optional<job_clock::time_point> ended_before,
                                                      std::optional<std::size_t> keep_newest,
                                                      std::size_t batch) {
    if (!ended_before && !keep_newest) return std::size_t{0};
    std::lock_guard lock(mutex_);
    connection c{db_, path_};
    transaction tx(c);
    if (auto r = tx.begin(true); !r) return r.error();
    // Ids are time-ordered: the newest ended jobs are those of the highest ids. -1: no age limit, and
    // SQLite's LIMIT -1: no count limit. Events, transitions and restore commands go by ON DELETE CASCADE.
    auto s = c.prepare(
        "DELETE FROM jobs WHERE id IN (SELECT id FROM jobs"
        " WHERE state IN ('succeeded', 'failed', 'cancelled') AND (finished_ms < ?1 OR id NOT IN"
        " (SELECT id FROM jobs WHERE state IN ('succeeded', 'failed', 'cancelled') ORDER BY id DESC LIMIT "
        "?2))"
        " ORDER BY id LIMIT ?3)");
    if (!s) return s.error();
    s->integer(1, ended_before ? epoch_ms(*ended_before) : std::int64_t{-1})
        .integer(2, keep_newest ? to_int64(*keep_newest) : std::int64_t{-1})
        .integer(3, to_int64(batch));
    if (s->step() != SQLITE_DONE) return c.error("delete ended jobs");
    const auto deleted = static_cast<std::size_t>(sqlite3_changes(c.db));
    if (auto r = tx.commit(); !r) return r.error();
    return deleted;
}

operation_result<std::optional<job_record>> job_store::find(const std::string& id) const {
    std::lock_guard lock(read_mutex_);
    return find_one(connection{reader_, path_}, "id", id);
}

operation_result<std::optional<job_record>> job_store::find_by_idempotency_key(const std::string& key) const {
    std::lock_guard lock(read_mutex_);
    return find_one(connection{reader_, path_}, "idempotency_key", key);
}

operation_result<job_page> job_store::list(const job_filter& filter) const {
    if (filter.limit < 1 || filter.limit > max_list_limit)
        return make_error(operation_error_kind::invalid_value,
                          fmt::format("limit must be 1..{} (got {})", max_list_limit, filter.limit), "limit");
    std::lock_guard lock(read_mutex_);
    connection c{reader_, path_};
    transaction tx(c);
    if (auto r = tx.begin(false); !r) return r.error();

    // The WHERE clause is assembled from fixed fragments; every value is a bound parameter.
    std::string sql = fmt::format("SELECT {} FROM jobs", job_columns);
    const char* glue = " WHERE ";
    auto add = [&](bool present, std::string_view condition) {
        if (!present) return;
        sql += glue;
        sql += condition;
        glue = " AND ";
    };
    add(filter.controller.has_value(), "controller = :controller");
    add(filter.type.has_value(), "type = :type");
    add(filter.state.has_value(), "state = :state");
    add(filter.before.has_value(), "id < :before");
    sql += " ORDER BY id DESC LIMIT :limit";

    auto s = c.prepare(sql);
    if (!s) return s.error();
    if (filter.controller) s->text(":controller", *filter.controller);
    if (filter.type) s->text(":type", to_string(*filter.type));
    if (filter.state) s->text(":state", to_string(*filter.state));
    if (filter.before) s->text(":before", *filter.before);
    s->integer(":limit", static_cast<std::int64_t>(filter.limit) + 1);  // one more: is there a next page?
    auto jobs = read_jobs(*s, c);
    if (!jobs) return jobs.error();
    if (auto r = tx.commit(); !r) return r.error();

    job_page page;
    if (jobs->size() > filter.limit) {
        jobs->resize(filter.limit);
        page.next = jobs->back().id;
    }
    page.jobs = std::move(*jobs);
    return page;
}

operation_result<std::vector<nlohmann::json>> job_store::events(const std::string& job_id,
                                                                std::size_t limit) const {
    std::lock_guard lock(read_mutex_);
    connection c{reader_, path_};
    transaction tx(c);
    if (auto r = tx.begin(false); !r) return r.error();
    auto s = c.prepare("SELECT event FROM job_events WHERE job_id = ?1 ORDER BY seq LIMIT ?2");
    if (!s) return s.error();
    s->text(1, job_id).integer(2, to_int64(limit));
    std::vector<nlohmann::json> events;
    nlohmann::json fixed;  // the record's fixed fields, read once when a state event needs them
    for (;;) {
        int rc = s->step();
        if (rc == SQLITE_DONE) break;
        if (rc != SQLITE_ROW) return c.error(fmt::format("read events of job {}", job_id));
        auto e = nlohmann::json::parse(s->text(0), nullptr, false);
        if (e.is_discarded()) return corrupt(path_, fmt::format("an event of job {} is not JSON", job_id));
        // A state event stored without its record's fixed fields gets them back from the job's row.
        if (auto job = e.find("job"); job != e.end() && job->is_object() && !job->contains("id")) {
            if (fixed.is_null()) {
                auto record = find_one_in(c, "id", job_id);
                if (!record) return record.error();
                fixed = *record ? record_without_spec(**record, job_clock::now()) : nlohmann::json::object();
            }
            for (const auto key : fixed_record_fields) {
                if (auto it = fixed.find(key); it != fixed.end()) (*job)[std::string(key)] = *it;
            }
        }
        events.push_back(std::move(e));
    }
    if (auto r = tx.commit(); !r) return r.error();
    return events;
}

operation_result<std::vector<nlohmann::json>> job_store::transitions(const std::string& job_id) const {
    std::lock_guard lock(read_mutex_);
    connection c{reader_, path_};
    transaction tx(c);
    if (auto r = tx.begin(false); !r) return r.error();
    auto s = c.prepare(
        "SELECT from_state, to_state, reason, at_ms FROM job_transitions WHERE job_id = ?1 "
        "ORDER BY seq");
    if (!s) return s.error();
    s->text(1, job_id);
    std::vector<nlohmann::json> out;
    for (;;) {
        int rc = s->step();
        if (rc == SQLITE_DONE) break;
        if (rc != SQLITE_ROW) return c.error(fmt::format("read transitions of job {}", job_id));
        nlohmann::json t = {{"from", nullptr},
                            {"to", s->text(1)},
                            {"reason", s->text(2)},
                            {"at", format_timestamp(from_ms(s->integer(3)))}};
        if (!s->is_null(0)) t["from"] = s->text(0);
        out.push_back(std::move(t));
    }
    if (auto r = tx.commit(); !r) return r.error();
    return out;
}

operation_result<std::vector<job_record>> job_store::in_states(const std::vector<job_state>& states) const {
    auto names = nlohmann::json::array();
    for (auto st : states)
        names.push_back(std::string(to_string(st)));
    std::lock_guard lock(read_mutex_);
    connection c{reader_, path_};
    transaction tx(c);
    if (auto r = tx.begin(false); !r) return r.error();
    auto s = c.prepare(fmt::format(
        "SELECT {} FROM jobs WHERE state IN (SELECT value FROM json_each(?1)) ORDER BY id", job_columns));
    if (!s) return s.error();
    s->text(1, names.dump());
    auto jobs = read_jobs(*s, c);
    if (!jobs) return jobs.error();
    if (auto r = tx.commit(); !r) return r.error();
    return std::move(*jobs);
}

operation_result<void> job_store::set_restore_commands(const std::string& job_id,
                                                       const std::vector<std::string>& commands) {
    std::lock_guard lock(mutex_);
    connection c{db_, path_};
    transaction tx(c);
    if (auto r = tx.begin(true); !r) return r.error();
    if (commands.empty()) {
        auto d = c.prepare("DELETE FROM job_restore_commands WHERE job_id = ?1");
        if (!d) return d.error();
        d->text(1, job_id);
        if (d->step() != SQLITE_DONE) return c.error(fmt::format("clear restore commands of job {}", job_id));
        return tx.commit();
    }
    auto s = c.prepare(
        "INSERT INTO job_restore_commands (job_id, commands, updated_ms) VALUES (?1, ?2, ?3) "
        "ON CONFLICT(job_id) DO UPDATE SET commands = excluded.commands, updated_ms = excluded.updated_ms");
    if (!s) return s.error();
    s->text(1, job_id).text(2, dump(nlohmann::json(commands))).integer(3, epoch_ms(job_clock::now()));
    if (s->step() != SQLITE_DONE) {
        if (is_constraint(db_, SQLITE_CONSTRAINT_FOREIGNKEY))
            return make_error(operation_error_kind::unknown_job, fmt::format("no job {}", job_id));
        return c.error(fmt::format("store restore commands of job {}", job_id));
    }
    return tx.commit();
}

operation_result<std::vector<std::string>> job_store::jobs_with_restore_commands() const {
    std::lock_guard lock(read_mutex_);
    connection c{reader_, path_};
    transaction tx(c);
    if (auto r = tx.begin(false); !r) return r.error();
    auto s = c.prepare("SELECT job_id FROM job_restore_commands ORDER BY updated_ms, job_id");
    if (!s) return s.error();
    std::vector<std::string> out;
    int rc = SQLITE_ROW;
    while ((rc = s->step()) == SQLITE_ROW)
        out.emplace_back(s->text(0));
    if (rc != SQLITE_DONE) return c.error("list the jobs with restore commands");
    if (auto r = tx.commit(); !r) return r.error();
    return out;
}

operation_result<std::vector<std::string>> job_store::restore_commands(const std::string& job_id) const {
    std::lock_guard lock(read_mutex_);
    connection c{reader_, path_};
    transaction tx(c);
    if (auto r = tx.begin(false); !r) return r.error();
    auto s = c.prepare("SELECT commands FROM job_restore_commands WHERE job_id = ?1");
    if (!s) return s.error();
    s->text(1, job_id);
    std::vector<std::string> out;
    int rc = s->step();
    if (rc == SQLITE_ROW) {
        auto list = nlohmann::json::parse(s->text(0), nullptr, false);
        const bool strings = list.is_array() && std::all_of(list.begin(), list.end(),
                                                            [](const auto& e) { return e.is_string(); });
        if (!strings)
            return corrupt(
                path_, fmt::format("the restore commands of job {} are not a JSON array of strings", job_id));
        for (const auto& e : list)
            out.push_back(e.get<std::string>());
    } else if (rc != SQLITE_DONE) {
        return c.error(fmt::format("read restore commands of job {}", job_id));
    }
    if (auto r = tx.commit(); !r) return r.error();
    return out;
}

operation_result<void> job_store::flush() {
    std::lock_guard lock(mutex_);
    connection c{db_, path_};
    auto s = c.prepare("PRAGMA wal_checkpoint(TRUNCATE)");
    if (!s) return s.error();
    int rc = s->step();
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) return c.error("checkpoint");
    return {};
}

operation_result<job_store::fill_level> job_store::fill() const {
    std::lock_guard lock(mutex_);
    connection c{db_, path_};
    auto pages = pragma_integer(c, "PRAGMA page_count", "read page count");
    if (!pages) return pages.error();
    // Free pages (history deleted, a table dropped) are taken again before the file grows.
    auto free = pragma_integer(c, "PRAGMA freelist_count", "read free pages");
    if (!free) return free.error();
    auto size = pragma_integer(c, "PRAGMA page_size", "read page size");
    if (!size) return size.error();
    auto limit = pragma_integer(c, "PRAGMA max_page_count", "read max page count");
    if (!limit) return limit.error();
    fill_level f;
    f.used_bytes = (*pages - *free) * *size;
    // SQLite's default maximum (about 4 billion pages) means no limit was set.
    f.limit_bytes = *limit >= 0xFFFFFFFE ? 0 : *limit * *size;
    return f;
}

}  // namespace gw::jobs
