#pragma once
// Where the job store lives. The default must not depend on the working directory the gateway was
// started from: a service started by systemd, by Docker or from a shell must find the same jobs.
//
//   1. --storage DIR (relative to the working directory, as every path on a command line is);
//   2. storage.path of the config file (relative to the config file's directory);
//   3. $STATE_DIRECTORY (systemd's StateDirectory=; its first entry);
//   4. $XDG_STATE_HOME/asi-gateway (an absolute $XDG_STATE_HOME only, as the XDG spec says);
//   5. $HOME/.local/state/asi-gateway.
// The result is absolute and lexically normal, so the log line says exactly where the jobs are.

#include <functional>
#include <optional>
#include <string>

#include <boost/system/result.hpp>

namespace gw {

// Reads one environment variable; nullopt when it is unset or empty.
using environment = std::function<std::optional<std::string>(const char* name)>;

// The process's own environment.
environment process_environment();

struct storage_path_inputs {
    std::string flag;               // --storage; empty when not given
    std::string configured;         // storage.path from the config file; empty when not given
    std::string config_file;        // the config file's path (for a relative storage.path); empty: none
    std::string working_directory;  // absolute
};

struct storage_path_error {
    std::string message;
};

// The directory of the job store, or why there is none (no HOME and nothing else set).
boost::system::result<std::string, storage_path_error> resolve_storage_path(const storage_path_inputs& in,
                                                                            const environment& env);

}  // namespace gw
