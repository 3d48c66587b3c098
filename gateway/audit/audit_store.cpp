#include "gateway/audit/audit_store.hpp"

#include <sqlite3.h>

#include "gateway/storage/sqlite_file.hpp"

namespace gw::audit {

namespace {

constexpr const char* schema = R"sql(
CREATE TABLE IF NOT EXISTS audit (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  time_ms INTEGER NOT NULL,
  principal TEXT NOT NULL,
  role TEXT NOT NULL,
  transport TEXT NOT NULL,
  address TEXT NOT NULL,
  action TEXT NOT NULL,
  controller TEXT NOT NULL,
  target TEXT NOT NULL,
  request_id TEXT NOT NULL,
  status INTEGER NOT NULL,
  outcome TEXT NOT NULL,
  detail TEXT NOT NULL);
CREATE INDEX IF NOT EXISTS audit_time ON audit(time_ms);
CREATE INDEX IF NOT EXISTS audit_controller ON audit(controller, id);
CREATE INDEX IF NOT EXISTS audit_principal ON audit(principal, id);
)sql";

using sqlite::bind_text;
using sqlite::column_text;
using sqlite::error_of;
using sqlite::statement;

}  // namespace

boost::system::result<std::unique_ptr<audit_store>, std::string> audit_store::open(
    const std::string& directory) {
    using result = boost::system::result<std::unique_ptr<audit_store>, std::string>;
    auto file = sqlite::open_file(directory, "audit.sqlite3", schema, "cannot prepare the audit table");
    if (!file) return result(boost::system::in_place_error, file.error());
    return std::unique_ptr<audit_store>(new audit_store(file->db, file->path));
}

audit_store::~audit_store() {
    sqlite3_close(db_);
}

boost::system::result<void, std::string> audit_store::append(std::vector<audit_entry>& entries) {
    using result = boost::system::result<void, std::string>;
    if (entries.empty()) return {};
    if (sqlite3_exec(db_, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr) != SQLITE_OK)
        return result(boost::system::in_place_error, error_of(db_, path_, "cannot begin"));
    statement insert;
    sqlite3_prepare_v2(db_,
                       "INSERT INTO audit (time_ms, principal, role, transport, address, action, controller, "
                       "target, request_id, status, outcome, detail) VALUES (?,?,?,?,?,?,?,?,?,?,?,?)",
                       -1, &insert.s, nullptr);
    for (auto& e : entries) {
        sqlite3_reset(insert.s);
        sqlite3_bind_int64(insert.s, 1, e.time_ms);
        bind_text(insert.s, 2, e.principal);
        bind_text(insert.s, 3, e.role);
        bind_text(insert.s, 4, e.transport);
        bind_text(insert.s, 5, e.address);
        bind_text(insert.s, 6, e.action);
        bind_text(insert.s, 7, e.controller);
        bind_text(insert.s, 8, e.target);
        bind_text(insert.s, 9, e.request_id);
        sqlite3_bind_int(insert.s, 10, e.status);
        bind_text(insert.s, 11, e.outcome);
        bind_text(insert.s, 12, e.detail.dump());
        if (!insert.s || sqlite3_step(insert.s) != SQLITE_DONE) {
            auto why = error_of(db_, path_, "cannot append");
            sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
            return result(boost::system::in_place_error, std::move(why));
        }
        e.id = sqlite3_last_insert_rowid(db_);
    }
    if (sqlite3_exec(db_, "COMMIT", nullptr, nullptr, nullptr) != SQLITE_OK) {
        auto why = error_of(db_, path_, "cannot commit");
        sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
        return result(boost::system::in_place_error, std::move(why));
    }
    return {};
}

boost::system::result<audit_page, std::string> audit_store::query(const audit_filter& f) const {
    using result = boost::system::result<audit_page, std::string>;
    // Every condition is always there, switched off by a NULL parameter: one statement for every filter.
    statement q;
    if (sqlite3_prepare_v2(
            db_,
            "SELECT id, time_ms, principal, role, transport, address, action, controller, target, "
            "request_id, status, outcome, detail FROM audit "
            "WHERE (?1 IS NULL OR controller = ?1) AND (?2 IS NULL OR principal = ?2) "
            "AND (?3 IS NULL OR time_ms >= ?3) AND (?4 IS NULL OR time_ms < ?4) "
            "AND (?5 IS NULL OR id < ?5) ORDER BY id DESC LIMIT ?6",
            -1, &q.s, nullptr) != SQLITE_OK)
        return result(boost::system::in_place_error, error_of(db_, path_, "cannot query"));
    if (f.controller) bind_text(q.s, 1, *f.controller);
    if (f.principal) bind_text(q.s, 2, *f.principal);
    if (f.since_ms) sqlite3_bind_int64(q.s, 3, *f.since_ms);
    if (f.until_ms) sqlite3_bind_int64(q.s, 4, *f.until_ms);
    if (f.before_id) sqlite3_bind_int64(q.s, 5, *f.before_id);
    sqlite3_bind_int64(q.s, 6, static_cast<sqlite3_int64>(f.limit));
    audit_page page;
    int rc = SQLITE_ROW;
    while ((rc = sqlite3_step(q.s)) == SQLITE_ROW) {
        audit_entry e;
        e.id = sqlite3_column_int64(q.s, 0);
        e.time_ms = sqlite3_column_int64(q.s, 1);
        e.principal = column_text(q.s, 2);
        e.role = column_text(q.s, 3);
        e.transport = column_text(q.s, 4);
        e.address = column_text(q.s, 5);
        e.action = column_text(q.s, 6);
        e.controller = column_text(q.s, 7);
        e.target = column_text(q.s, 8);
        e.request_id = column_text(q.s, 9);
        e.status = sqlite3_column_int(q.s, 10);
        e.outcome = column_text(q.s, 11);
        e.detail = nlohmann::json::parse(column_text(q.s, 12), nullptr, false);
        page.entries.push_back(std::move(e));
    }
    if (rc != SQLITE_DONE) return result(boost::system::in_place_error, error_of(db_, path_, "cannot read"));
    if (page.entries.size() == f.limit && !page.entries.empty()) page.next_before = page.entries.back().id;
    return page;
}

boost::system::result<std::size_t, std::string> audit_store::delete_old(
    std::optional<std::int64_t> before_ms, std::optional<std::size_t> keep_newest, std::size_t batch) {
    using result = boost::system::result<std::size_t, std::string>;
    if (!before_ms && !keep_newest) return std::size_t{0};
    // Ids grow with time: the newest entries are those of the highest ids. -1: no limit of that kind.
    statement st;
    if (sqlite3_prepare_v2(
            db_,
            "DELETE FROM audit WHERE id IN (SELECT id FROM audit WHERE time_ms < ?1 OR id NOT IN "
            "(SELECT id FROM audit ORDER BY id DESC LIMIT ?2) ORDER BY id LIMIT ?3)",
            -1, &st.s, nullptr) != SQLITE_OK)
        return result(boost::system::in_place_error, error_of(db_, path_, "delete old entries"));
    sqlite3_bind_int64(st.s, 1, before_ms.value_or(-1));
    sqlite3_bind_int64(st.s, 2, keep_newest ? static_cast<std::int64_t>(*keep_newest) : -1);
    sqlite3_bind_int64(st.s, 3, static_cast<std::int64_t>(batch));
    if (sqlite3_step(st.s) != SQLITE_DONE)
        return result(boost::system::in_place_error, error_of(db_, path_, "delete old entries"));
    return static_cast<std::size_t>(sqlite3_changes(db_));
}

}  // namespace gw::audit
