#pragma once
// The controller's internal error log (DUMP Y, "DU Y"): diagnostic codes the firmware appends by
// itself, such as a move clamped at a limit or an encoder report lost because triggers came faster
// than the report port could send. They are never answers (":N-x" is another list, doc §2.2). Pure.

#include <optional>
#include <string_view>
#include <vector>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/reply.hpp"

namespace gw::devices::ms2000 {

inline constexpr int ttl_report_buffer_overrun = 87;  // seed 003: "appended to the internal error log"

command read_error_log();   // "DU Y": ":A 34 87 ", oldest first
command clear_error_log();  // "DU X"

// The codes of a DU Y answer, oldest first; nullopt if a value is not a code (an integer 0..9999).
std::optional<std::vector<int>> error_log_codes(const reply& r);

// The firmware's name of a code: "TTL_REPORT_BUFFER_OVERRUN" for 87, "UPPER_LIMIT" for 34,
// "UNKNOWN" for a code the protocol reference does not list.
std::string_view error_log_name(int code);

// What a read adds to an earlier one since the last clear: the codes after it when the earlier read
// is where this one starts (the log only grows until cleared), all of them otherwise (the log was
// cleared by someone else meanwhile, or power-cycled).
std::vector<int> new_error_log_codes(const std::vector<int>& seen, const std::vector<int>& now);

}  // namespace gw::devices::ms2000
