#pragma once
// The gateway's wall-clock time stamps in events: ISO 8601 UTC with milliseconds and epoch milliseconds.
// Pure: formats the time point it is given.

#include <chrono>
#include <cstdint>
#include <string>

namespace gw {

// "2026-11-22T02:45:40.123Z" (truncated to the millisecond).
std::string format_timestamp(std::chrono::system_clock::time_point t);
// Milliseconds since 1970-01-01T00:00:00Z (truncated).
std::int64_t epoch_ms(std::chrono::system_clock::time_point t);

}  // namespace gw
