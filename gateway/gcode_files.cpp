#include "gateway/gcode_files.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <sstream>
#include <system_error>
#include <unistd.h>

#include "gateway/jobs/job_id.hpp"
#include "gateway/timestamp.hpp"

namespace gw {

namespace fs = std::filesystem;

namespace {

constexpr std::string_view id_prefix = "g-";

operation_error storage_error(const std::string& what, int err) {
    return make_error(operation_error_kind::storage_unavailable,
                      "G-code store: " + what + ": " + std::strerror(err));
}

operation_error unknown(std::string_view id) {
    return make_error(operation_error_kind::unknown_file, "no G-code file \"" + std::string(id) + "\"");
}

// Closes a descriptor and removes a temporary file unless released.
class temp_file {
  public:
    explicit temp_file(fs::path path) : path_(std::move(path)) {}
    temp_file(const temp_file&) = delete;
    temp_file& operator=(const temp_file&) = delete;
    ~temp_file() {
        if (fd_ >= 0) ::close(fd_);
        if (!released_) {
            std::error_code ignored;
            fs::remove(path_, ignored);
        }
    }
    int open() {
        fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
        return fd_ >= 0 ? 0 : errno;
    }
    int write_all(const char* data, std::size_t n) {
        while (n > 0) {
            const ssize_t w = ::write(fd_, data, n);
            if (w < 0) {
                if (errno == EINTR) continue;
                return errno;
            }
            data += w;
            n -= static_cast<std::size_t>(w);
        }
        return 0;
    }
    // fsync, close, rename into place: the file exists whole or not at all.
    int commit(const fs::path& to) {
        if (::fsync(fd_) != 0) return errno;
        const int fd = fd_;
        fd_ = -1;
        if (::close(fd) != 0) return errno;
        if (::rename(path_.c_str(), to.c_str()) != 0) return errno;
        released_ = true;
        return 0;
    }
    const fs::path& path() const { return path_; }

  private:
    fs::path path_;
    int fd_ = -1;
    bool released_ = false;
};

std::string meta_text(const gcode_file_info& info) {
    nlohmann::json j = {{"id", info.id},
                        {"name", info.name},
                        {"bytes", info.bytes},
                        {"lines", info.lines},
                        {"created_ms", info.created_ms}};
    return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

std::optional<gcode_file_info> parse_meta(const std::string& text) {
    auto j = nlohmann::json::parse(text, nullptr, false);
    if (!j.is_object()) return std::nullopt;
    try {
        gcode_file_info info;
        info.id = j.at("id").get<std::string>();
        info.name = j.at("name").get<std::string>();
        info.bytes = j.at("bytes").get<std::uint64_t>();
        info.lines = j.at("lines").get<std::uint64_t>();
        info.created_ms = j.at("created_ms").get<std::int64_t>();
        return info;
    } catch (const nlohmann::json::exception&) {
        return std::nullopt;
    }
}

std::optional<std::string> check_name(std::string_view name) {
    if (name.size() > max_gcode_file_name_chars)
        return "the name is longer than " + std::to_string(max_gcode_file_name_chars) + " bytes";
    for (const char c : name) {
        const auto u = static_cast<unsigned char>(c);
        if (u < 0x20 || u == 0x7f) return "the name holds a control character";
    }
    return std::nullopt;
}

}  // namespace

bool is_gcode_file_id(std::string_view id) {
    if (!id.starts_with(id_prefix)) return false;
    return jobs::is_job_id("j-" + std::string(id.substr(id_prefix.size())));
}

gcode_file_store::gcode_file_store(gcode_file_store_settings settings) : settings_(std::move(settings)) {}

fs::path gcode_file_store::program_path(std::string_view id) const {
    return settings_.directory / (std::string(id) + ".gcode");
}

fs::path gcode_file_store::meta_path(std::string_view id) const {
    return settings_.directory / (std::string(id) + ".json");
}

operation_result<gcode_file_info> gcode_file_store::save(std::istream& program, std::string_view name) {
    if (auto why = check_name(name)) return make_error(operation_error_kind::invalid_value, *why, "name");
    std::error_code ec;
    fs::create_directories(settings_.directory, ec);
    if (ec) return storage_error("cannot create " + settings_.directory.string(), ec.value());

    gcode_file_info info;
    info.id = std::string(id_prefix) + jobs::make_job_id().substr(2);
    info.name = name.empty() ? "untitled" : std::string(name);
    info.created_ms = epoch_ms(std::chrono::system_clock::now());

    temp_file program_tmp(settings_.directory / ("." + info.id + ".gcode.tmp"));
    if (int err = program_tmp.open())
        return storage_error("cannot write " + program_tmp.path().string(), err);
    std::array<char, std::size_t{64} * 1024> buf{};
    char last = '\n';
    while (program) {
        program.read(buf.data(), buf.size());
        const auto n = static_cast<std::size_t>(program.gcount());
        if (n == 0) break;
        info.bytes += n;
        if (info.bytes > settings_.max_file_bytes)
            return make_error(operation_error_kind::invalid_value,
                              "the program is larger than " + std::to_string(settings_.max_file_bytes) +
                                  " bytes (gcode.max_file_mb)",
                              "body");
        info.lines += static_cast<std::uint64_t>(std::count(buf.data(), buf.data() + n, '\n'));
        last = buf[n - 1];
        if (int err = program_tmp.write_all(buf.data(), n))
            return storage_error("cannot write " + program_tmp.path().string(), err);
    }
    if (program.bad())
        return make_error(operation_error_kind::internal, "G-code store: the upload could not be read");
    if (last != '\n') ++info.lines;

    // The metadata first: a program file is only listed through its metadata, so a crash between the
    // two renames leaves an orphan .json that get() reports as unknown, never a half-described program.
    temp_file meta_tmp(settings_.directory / ("." + info.id + ".json.tmp"));
    if (int err = meta_tmp.open()) return storage_error("cannot write " + meta_tmp.path().string(), err);
    const std::string meta = meta_text(info);
    if (int err = meta_tmp.write_all(meta.data(), meta.size()))
        return storage_error("cannot write " + meta_tmp.path().string(), err);
    if (int err = program_tmp.commit(program_path(info.id)))
        return storage_error("cannot store " + program_path(info.id).string(), err);
    if (int err = meta_tmp.commit(meta_path(info.id))) {
        std::error_code ignored;
        fs::remove(program_path(info.id), ignored);
        return storage_error("cannot store " + meta_path(info.id).string(), err);
    }
    return info;
}

operation_result<gcode_file_info> gcode_file_store::get(std::string_view id) const {
    if (!is_gcode_file_id(id)) return unknown(id);
    std::ifstream in(meta_path(id));
    if (!in) {
        if (errno == ENOENT || errno == ENOTDIR) return unknown(id);
        return storage_error("cannot read " + meta_path(id).string(), errno);
    }
    std::ostringstream text;
    text << in.rdbuf();
    auto info = parse_meta(text.str());
    std::error_code ec;
    if (!info || info->id != id || !fs::is_regular_file(program_path(id), ec)) return unknown(id);
    return *info;
}

operation_result<std::vector<gcode_file_info>> gcode_file_store::list() const {
    std::vector<gcode_file_info> out;
    std::error_code ec;
    if (!fs::exists(settings_.directory, ec)) return out;
    fs::directory_iterator it(settings_.directory, ec);
    if (ec) return storage_error("cannot list " + settings_.directory.string(), ec.value());
    for (; it != fs::directory_iterator(); it.increment(ec)) {
        if (ec) return storage_error("cannot list " + settings_.directory.string(), ec.value());
        const auto& p = it->path();
        if (p.extension() != ".json") continue;
        const std::string id = p.stem().string();
        if (!is_gcode_file_id(id)) continue;
        if (auto info = get(id)) out.push_back(std::move(*info));
    }
    std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.id > b.id; });
    return out;
}

operation_result<void> gcode_file_store::remove(std::string_view id) {
    auto info = get(id);
    if (!info) return info.error();
    std::error_code ec;
    fs::remove(meta_path(id), ec);  // unlisted first: a failure below leaves no half entry
    if (ec) return storage_error("cannot delete " + meta_path(id).string(), ec.value());
    fs::remove(program_path(id), ec);
    if (ec) return storage_error("cannot delete " + program_path(id).string(), ec.value());
    return {};
}

operation_result<fs::path> gcode_file_store::path_of(std::string_view id) const {
    auto info = get(id);
    if (!info) return info.error();
    return program_path(id);
}

nlohmann::json to_json(const gcode_file_info& info) {
    return {{"id", info.id},
            {"name", info.name},
            {"bytes", info.bytes},
            {"lines", info.lines},
            {"created", format_timestamp(std::chrono::system_clock::time_point(
                            std::chrono::milliseconds(info.created_ms)))}};
}

}  // namespace gw
