#include "gateway/config/secret_file_path.hpp"

namespace gw {

namespace {

constexpr std::string_view credentials_variable = "$CREDENTIALS_DIRECTORY";

}  // namespace

boost::system::result<std::string, secret_file_problem> resolve_secret_file_path(
    std::string_view key, std::string_view given, std::string_view config_directory,
    std::optional<std::string> credentials_directory) {
    std::string path(given);
    const auto named = std::string(key) + ": " + std::string(given);
    if (given.starts_with(credentials_variable)) {
        const auto rest = given.substr(credentials_variable.size());
        if (!rest.empty() && rest.front() != '/')
            return secret_file_problem{named + ": only \"$CREDENTIALS_DIRECTORY/<name>\" is expanded"};
        if (!credentials_directory || credentials_directory->empty())
            return secret_file_problem{
                named + ": CREDENTIALS_DIRECTORY is not set (systemd sets it for LoadCredential=)"};
        path = *credentials_directory + std::string(rest);
    } else if (!path.empty() && path.front() != '/' && !config_directory.empty()) {
        path = std::string(config_directory) + "/" + path;
    }
    return {boost::system::in_place_value, path};
}

}  // namespace gw
