#include "gateway/storage/sqlite_file.hpp"

#include <filesystem>
#include <sqlite3.h>

namespace gw::sqlite {

boost::system::result<opened_file, std::string> open_file(const std::string& directory,
                                                          const std::string& file_name, const char* schema,
                                                          const char* what) {
    using result = boost::system::result<opened_file, std::string>;
    std::error_code ec;
    std::filesystem::create_directories(directory, ec);
    opened_file out;
    out.path = (std::filesystem::path(directory) / file_name).string();
    if (ec)
        return result(boost::system::in_place_error,
                      out.path + ": cannot create the directory: " + ec.message());
    if (sqlite3_open_v2(out.path.c_str(), &out.db,
                        SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                        nullptr) != SQLITE_OK) {
        auto why = error_of(out.db, out.path, "cannot open");
        sqlite3_close(out.db);
        return result(boost::system::in_place_error, std::move(why));
    }
    sqlite3_busy_timeout(out.db, 5000);
    for (const char* sql : {"PRAGMA journal_mode = WAL", "PRAGMA synchronous = NORMAL", schema}) {
        if (sqlite3_exec(out.db, sql, nullptr, nullptr, nullptr) != SQLITE_OK) {
            auto why = error_of(out.db, out.path, what);
            sqlite3_close(out.db);
            return result(boost::system::in_place_error, std::move(why));
        }
    }
    return out;
}

statement::~statement() {
    sqlite3_finalize(s);
}

std::string error_of(sqlite3* db, const std::string& path, const char* what) {
    return path + ": " + what + ": " + sqlite3_errmsg(db);
}

void bind_text(sqlite3_stmt* s, int index, const std::string& text) {
    sqlite3_bind_text(s, index, text.data(), static_cast<int>(text.size()), SQLITE_TRANSIENT);
}

std::string column_text(sqlite3_stmt* s, int column) {
    const auto* text = reinterpret_cast<const char*>(sqlite3_column_text(s, column));
    return text ? std::string(text, static_cast<std::size_t>(sqlite3_column_bytes(s, column)))
                : std::string();
}

}  // namespace gw::sqlite
