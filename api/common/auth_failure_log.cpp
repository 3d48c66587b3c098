#include "api/common/auth_failure_log.hpp"

#include <chrono>
#include <cstdint>
#include <mutex>

#include <spdlog/spdlog.h>

#include "devices/serial/log_limiter.hpp"

namespace gw::api {

void log_failed_authentication(const std::shared_ptr<spdlog::logger>& log, std::string_view address,
                               std::string_view method, std::string_view route) {
    static std::mutex mutex;
    static devices::log_limiter limiter;
    std::uint64_t suppressed = 0;
    {
        std::lock_guard lock(mutex);
        if (!limiter.allow(std::chrono::steady_clock::now(), suppressed)) return;
    }
    if (!log) return;
    if (suppressed > 0)
        log->info("authentication failed from {}: {} {} ({} more not logged)", address, method, route,
                  suppressed);
    else
        log->info("authentication failed from {}: {} {}", address, method, route);
}

}  // namespace gw::api
