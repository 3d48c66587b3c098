#pragma once
// What the gateway's SQLite files share: the audit trail (gateway/audit) and the recordings
// (gateway/recordings) open their file the same way (the directory created, WAL, synchronous NORMAL,
// their schema) and use the same small helpers for statements. The job store opens its own (two
// connections, size limits: gateway/jobs/store).

#include <string>

#include <boost/system/result.hpp>

struct sqlite3;
struct sqlite3_stmt;

namespace gw::sqlite {

struct opened_file {
    sqlite3* db = nullptr;  // the caller's to close
    std::string path;
};

// <directory>/<file_name>, created with the directory if needed; WAL with synchronous NORMAL (a commit
// is durable at the next checkpoint); `schema` run. The error names the file and what failed (`what`:
// "cannot prepare the audit table").
boost::system::result<opened_file, std::string> open_file(const std::string& directory,
                                                          const std::string& file_name, const char* schema,
                                                          const char* what);

// A prepared statement, finalized on every path.
struct statement {
    sqlite3_stmt* s = nullptr;
    statement() = default;
    statement(const statement&) = delete;
    statement& operator=(const statement&) = delete;
    ~statement();
};

// "<path>: <what>: <SQLite's message>".
std::string error_of(sqlite3* db, const std::string& path, const char* what);
void bind_text(sqlite3_stmt* s, int index, const std::string& text);
// The column's text ("" for NULL), its bytes as stored.
std::string column_text(sqlite3_stmt* s, int column);

}  // namespace gw::sqlite
