#pragma once
// Failed authentications (401) at info level, for an admin who wants to see who knocks: rate-limited
// across every connection (devices/serial/log_limiter: the 1st, 2nd, 4th, ... of each 10 s), so that a
// client that tries tokens in a loop does not flood the log. Thread-safe.

#include <memory>
#include <string_view>

namespace spdlog {
class logger;
}

namespace gw::api {

// Logs "authentication failed from <address>: <method> <route>" when the limiter lets it through.
void log_failed_authentication(const std::shared_ptr<spdlog::logger>& log, std::string_view address,
                               std::string_view method, std::string_view route);

}  // namespace gw::api
