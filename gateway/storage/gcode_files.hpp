#pragma once
// Uploaded G-code programs: one directory (<storage.path>/gcode/) holding <id>.gcode (the program as
// sent) and <id>.json (its metadata). Ids are "g-" + the 26 characters of a job id (time stamp then
// random, so string order is upload order). The store keeps no state besides the directory, so
// several instances (the API's, a job's) may share it; every call is a few file operations and blocks:
// call it off the I/O threads for big programs.
//
//   gcode_file_store store({.directory = "data/gcode", .max_file_bytes = 64 << 20});
//   auto meta = store.save(body_stream, "part.ngc");   // {"id":"g-01J...","name":"part.ngc",...}
//   auto path = store.path_of(meta->id);               // what a gcode job runs
//
//   auto upload = store.begin_upload();                // a body streamed in as it arrives
//   upload.append(chunk); ...                          // on disk at once, never whole in memory
//   auto meta = store.commit(std::move(upload), "part.ngc");
//
// Errors: unknown_file (no such id, or not an id at all), invalid_value (over the size cap, a bad
// name), storage_unavailable (the directory cannot be created or written: disk full, read-only).

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <istream>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "gateway/common/operation_error.hpp"

namespace gw {

// <storage.path>/gcode: where uploaded programs are kept (the API's store and the gcode job read the
// same). Empty when there is no storage path.
std::filesystem::path gcode_directory(const std::filesystem::path& storage_path);

struct gcode_file_info {
    std::string id;
    std::string name;             // given at upload ("untitled" when none)
    std::uint64_t bytes = 0;      // size of the program
    std::uint64_t lines = 0;      // newline count, plus one for a last line without a newline
    std::int64_t created_ms = 0;  // upload time, epoch milliseconds

    bool operator==(const gcode_file_info&) const = default;
};

struct gcode_file_store_settings {
    std::filesystem::path directory;  // created on the first save
    std::size_t max_file_bytes = std::size_t{64} * 1024 * 1024;
};

inline constexpr std::size_t max_gcode_file_name_chars = 255;

// "g-" + 26 Crockford base32 characters (the shape of a job id). Only such ids reach the file system.
bool is_gcode_file_id(std::string_view id);

// A program's name is metadata only: 0..255 bytes without control characters (invalid_value "name").
operation_result<void> check_gcode_file_name(std::string_view name);

// A program on its way into the store (an HTTP body, as it arrives): written to a hidden temporary
// file in the store's directory (created by the first append), counted (bytes, lines) and capped at
// max_file_bytes. gcode_file_store::commit makes it a stored program; an upload destroyed uncommitted
// leaves nothing behind. Blocking file I/O; used by one thread at a time (it may move between threads).
class gcode_upload {
  public:
    gcode_upload(gcode_upload&& o) noexcept;
    gcode_upload& operator=(gcode_upload&&) = delete;
    gcode_upload(const gcode_upload&) = delete;
    gcode_upload& operator=(const gcode_upload&) = delete;
    ~gcode_upload();

    // The next bytes of the program. invalid_value past max_file_bytes ("body"), storage_unavailable
    // when the file cannot be written; after an error nothing more is written.
    operation_result<void> append(std::string_view data);
    // The temporary file holding what was appended (created if nothing was), for reading in place: a
    // plan or a preview of a program that is not kept.
    operation_result<std::filesystem::path> contents();
    std::uint64_t bytes() const { return info_.bytes; }

  private:
    friend class gcode_file_store;
    gcode_upload(std::filesystem::path directory, std::size_t max_file_bytes);
    operation_result<void> open_file();  // creates the directory and the file if not yet done

    std::filesystem::path directory_;
    std::size_t max_file_bytes_;
    gcode_file_info info_;  // id, created_ms, bytes, lines so far
    char last_ = '\n';
    std::filesystem::path temp_path_;
    int fd_ = -1;
    bool created_ = false;  // the temporary file exists (until committed or destroyed)
    bool failed_ = false;
    bool committed_ = false;
};

class gcode_file_store {
  public:
    explicit gcode_file_store(gcode_file_store_settings settings);

    // Copies `program` into the store (a temporary file renamed into place: a failed or oversized
    // upload leaves nothing behind). `name`: see check_gcode_file_name.
    operation_result<gcode_file_info> save(std::istream& program, std::string_view name);
    // An upload to append a program to as it arrives; nothing touches the disk before its first append.
    gcode_upload begin_upload() const;
    // Stores an upload as a program named `name` (synced, then renamed into place with its metadata).
    operation_result<gcode_file_info> commit(gcode_upload upload, std::string_view name);
    // Every stored program, newest first.
    operation_result<std::vector<gcode_file_info>> list() const;
    operation_result<gcode_file_info> get(std::string_view id) const;
    operation_result<void> remove(std::string_view id);
    // The program file of `id`, for reading (the planner, a gcode job).
    operation_result<std::filesystem::path> path_of(std::string_view id) const;
    // Removes what uploads cut short by a crash left behind (the hidden ".*.tmp" files; a program
    // streamed in may be tens of megabytes). Only while nothing uploads: at start-up, under the
    // storage lock. Returns how many files went.
    std::size_t remove_stale_temporaries();

    const gcode_file_store_settings& settings() const { return settings_; }

  private:
    std::filesystem::path program_path(std::string_view id) const;
    std::filesystem::path meta_path(std::string_view id) const;

    gcode_file_store_settings settings_;
};

// The metadata as the API shows it: {"id","name","bytes","lines","created"} (created: RFC 3339 UTC).
nlohmann::json to_json(const gcode_file_info& info);

}  // namespace gw
