#pragma once
// Where a file the config names for a secret (auth.tokens_file, http.tls.cert_file and key_file) is:
//   - "$CREDENTIALS_DIRECTORY/<name>": systemd's LoadCredential= directory, from the environment;
//   - a relative path: from the config file's directory (like storage.path);
//   - an absolute path: as given.

#include <optional>
#include <string>
#include <string_view>

#include <boost/system/result.hpp>

namespace gw {

struct secret_file_problem {
    std::string message;
};

// The file's path, or why there is none (the variable it names is unset). `key` names the setting
// in the message ("auth.tokens_file").
boost::system::result<std::string, secret_file_problem> resolve_secret_file_path(
    std::string_view key, std::string_view given, std::string_view config_directory,
    std::optional<std::string> credentials_directory);

}  // namespace gw
