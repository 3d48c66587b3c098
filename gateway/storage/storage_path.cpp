#include "gateway/storage/storage_path.hpp"

#include <cstdlib>
#include <filesystem>

namespace gw {
namespace fs = std::filesystem;

environment process_environment() {
    return [](const char* name) -> std::optional<std::string> {
        const char* value = std::getenv(name);  // NOLINT(concurrency-mt-unsafe): read at start-up only
        if (value == nullptr || *value == '\0') return std::nullopt;
        return std::string(value);
    };
}

namespace {

std::string absolute_from(const fs::path& base, const fs::path& p) {
    return (p.is_absolute() ? p : base / p).lexically_normal().string();
}

using resolved = boost::system::result<std::string, storage_path_error>;

// Without the trailing separator that lexically_normal keeps for "dir/", so logs show one form.
resolved without_trailing_slash(std::string p) {
    while (p.size() > 1 && p.back() == '/')
        p.pop_back();
    return resolved(boost::system::in_place_value, std::move(p));
}

}  // namespace

resolved resolve_storage_path(const storage_path_inputs& in, const environment& env) {
    const fs::path cwd(in.working_directory);
    if (!in.flag.empty()) return without_trailing_slash(absolute_from(cwd, in.flag));
    if (!in.configured.empty()) {
        const fs::path config_dir =
            in.config_file.empty() ? cwd : fs::path(absolute_from(cwd, in.config_file)).parent_path();
        return without_trailing_slash(absolute_from(config_dir, in.configured));
    }
    if (auto state = env("STATE_DIRECTORY")) {
        // systemd gives a colon-separated list when the unit names several directories.
        const auto first = state->substr(0, state->find(':'));
        if (fs::path(first).is_absolute())
            return without_trailing_slash(fs::path(first).lexically_normal().string());
    }
    if (auto xdg = env("XDG_STATE_HOME"); xdg && fs::path(*xdg).is_absolute())
        return without_trailing_slash((fs::path(*xdg) / "asi-gateway").lexically_normal().string());
    if (auto home = env("HOME"); home && fs::path(*home).is_absolute())
        return without_trailing_slash(
            (fs::path(*home) / ".local/state/asi-gateway").lexically_normal().string());
    return resolved(
        boost::system::in_place_error,
        storage_path_error{"no storage directory: set HOME or XDG_STATE_HOME, or give --storage DIR"});
}

}  // namespace gw
