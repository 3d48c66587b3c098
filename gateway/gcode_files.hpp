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

#include "gateway/operation_error.hpp"

namespace gw {

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

class gcode_file_store {
  public:
    explicit gcode_file_store(gcode_file_store_settings settings);

    // Copies `program` into the store (a temporary file renamed into place: a failed or oversized
    // upload leaves nothing behind). `name` is metadata only: 0..255 bytes without control characters.
    operation_result<gcode_file_info> save(std::istream& program, std::string_view name);
    // Every stored program, newest first.
    operation_result<std::vector<gcode_file_info>> list() const;
    operation_result<gcode_file_info> get(std::string_view id) const;
    operation_result<void> remove(std::string_view id);
    // The program file of `id`, for reading (the planner, a gcode job).
    operation_result<std::filesystem::path> path_of(std::string_view id) const;

    const gcode_file_store_settings& settings() const { return settings_; }

  private:
    std::filesystem::path program_path(std::string_view id) const;
    std::filesystem::path meta_path(std::string_view id) const;

    gcode_file_store_settings settings_;
};

// The metadata as the API shows it: {"id","name","bytes","lines","created"} (created: RFC 3339 UTC).
nlohmann::json to_json(const gcode_file_info& info);

}  // namespace gw
