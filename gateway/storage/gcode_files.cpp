#include "gateway/storage/gcode_files.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <sstream>
#include <system_error>
#include <unistd.h>

#include "gateway/common/job_id.hpp"
#include "gateway/common/timestamp.hpp"

namespace gw {

std::filesystem::path gcode_directory(const std::filesystem::path& storage_path) {
    return storage_path.empty() ? std::filesystem::path{} : storage_path / "gcode";
}

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

int write_all(int fd, const char* data, std::size_t n) {
    while (n > 0) {
        const ssize_t w = ::write(fd, data, n);
        if (w < 0) {
            if (errno == EINTR) continue;
            return errno;
        }
        data += w;
        n -= static_cast<std::size_t>(w);
    }
    return 0;
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
    int write_all(const char* data, std::size_t n) { return gw::write_all(fd_, data, n); }
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

}  // namespace

operation_result<void> check_gcode_file_name(std::string_view name) {
    auto refuse = [](std::string why) {
        return make_error(operation_error_kind::invalid_value, std::move(why), "name");
    };
    if (name.size() > max_gcode_file_name_chars)
        return refuse("the name is longer than " + std::to_string(max_gcode_file_name_chars) + " bytes");
    for (const char c : name) {
        const auto u = static_cast<unsigned char>(c);
        if (u < 0x20 || u == 0x7f) return refuse("the name holds a control character");
    }
    return {};
}

gcode_upload::gcode_upload(fs::path directory, std::size_t max_file_bytes)
    : directory_(std::move(directory)), max_file_bytes_(max_file_bytes) {
    info_.id = std::string(id_prefix) + jobs::make_job_id().substr(2);
    info_.created_ms = epoch_ms(std::chrono::system_clock::now());
    temp_path_ = directory_ / ("." + info_.id + ".gcode.tmp");
}

gcode_upload::gcode_upload(gcode_upload&& o) noexcept
    : directory_(std::move(o.directory_)),
      max_file_bytes_(o.max_file_bytes_),
      info_(std::move(o.info_)),
      last_(o.last_),
      temp_path_(std::move(o.temp_path_)),
      fd_(o.fd_),
      created_(o.created_),
      failed_(o.failed_),
      committed_(o.committed_) {
    o.fd_ = -1;
    o.created_ = false;  // the moved-from upload owns no file
}

gcode_upload::~gcode_upload() {
    if (fd_ >= 0) ::close(fd_);
    if (created_ && !committed_) {
        std::error_code ignored;
        fs::remove(temp_path_, ignored);
    }
}

operation_result<void> gcode_upload::open_file() {
    if (fd_ >= 0) return {};
    std::error_code ec;
    fs::create_directories(directory_, ec);
    if (ec) return storage_error("cannot create " + directory_.string(), ec.value());
    fd_ = ::open(temp_path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd_ < 0) return storage_error("cannot write " + temp_path_.string(), errno);
    created_ = true;
    return {};
}

operation_result<void> gcode_upload::append(std::string_view data) {
    if (failed_) return make_error(operation_error_kind::internal, "G-code store: the upload failed before");
    auto fail = [this](operation_error e) {
        failed_ = true;
        return e;
    };
    if (data.empty()) return {};
    info_.bytes += data.size();
    if (info_.bytes > max_file_bytes_)
        return fail(make_error(
            operation_error_kind::invalid_value,
            "the program is larger than " + std::to_string(max_file_bytes_) + " bytes (gcode.max_file_mb)",
            "body"));
    if (auto opened = open_file(); !opened) return fail(opened.error());
    info_.lines += static_cast<std::uint64_t>(std::count(data.begin(), data.end(), '\n'));
    last_ = data.back();
    if (int err = write_all(fd_, data.data(), data.size()))
        return fail(storage_error("cannot write " + temp_path_.string(), err));
    return {};
}

operation_result<fs::path> gcode_upload::contents() {
    if (failed_) return make_error(operation_error_kind::internal, "G-code store: the upload failed before");
    if (auto opened = open_file(); !opened) return opened.error();
    return temp_path_;
}

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
    if (auto ok = check_gcode_file_name(name); !ok) return ok.error();
    auto upload = begin_upload();
    std::array<char, std::size_t{64} * 1024> buf{};
    while (program) {
        program.read(buf.data(), buf.size());
        const auto n = static_cast<std::size_t>(program.gcount());
        if (n == 0) break;
        if (auto ok = upload.append(std::string_view(buf.data(), n)); !ok) return ok.error();
    }
    if (program.bad())
        return make_error(operation_error_kind::internal, "G-code store: the upload could not be read");
    return commit(std::move(upload), name);
}

gcode_upload gcode_file_store::begin_upload() const {
    return gcode_upload(settings_.directory, settings_.max_file_bytes);
}

operation_result<gcode_file_info> gcode_file_store::commit(gcode_upload upload, std::string_view name) {
    if (auto ok = check_gcode_file_name(name); !ok) return ok.error();
    if (auto file = upload.contents(); !file) return file.error();  // an empty program is a file too
    gcode_file_info info = upload.info_;
    info.name = name.empty() ? "untitled" : std::string(name);
    if (upload.last_ != '\n') ++info.lines;

    // The metadata first: a program file is only listed through its metadata, so a crash between the
    // two renames leaves an orphan .json that get() reports as unknown, never a half-described program.
    temp_file meta_tmp(settings_.directory / ("." + info.id + ".json.tmp"));
    if (int err = meta_tmp.open()) return storage_error("cannot write " + meta_tmp.path().string(), err);
    const std::string meta = meta_text(info);
    if (int err = meta_tmp.write_all(meta.data(), meta.size()))
        return storage_error("cannot write " + meta_tmp.path().string(), err);
    // fsync, close, rename into place: the program exists whole or not at all.
    if (::fsync(upload.fd_) != 0)
        return storage_error("cannot store " + program_path(info.id).string(), errno);
    const int fd = upload.fd_;
    upload.fd_ = -1;
    if (::close(fd) != 0) return storage_error("cannot store " + program_path(info.id).string(), errno);
    if (::rename(upload.temp_path_.c_str(), program_path(info.id).c_str()) != 0)
        return storage_error("cannot store " + program_path(info.id).string(), errno);
    upload.committed_ = true;
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

std::size_t gcode_file_store::remove_stale_temporaries() {
    std::size_t removed = 0;
    std::error_code ec;
    for (fs::directory_iterator it(settings_.directory, ec), end; !ec && it != end; it.increment(ec)) {
        const auto name = it->path().filename().string();
        std::error_code ignored;  // one that cannot go does not stop the others
        if (name.starts_with(".") && name.ends_with(".tmp") && fs::remove(it->path(), ignored)) ++removed;
    }
    return removed;
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
