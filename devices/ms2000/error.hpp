#pragma once
// Errors of the MS-2000 layer.
//  * controller error codes: what the controller itself answers as ":N-<code>", kept signed (-1, -21)
//  * gw::devices::ms2000::error: what this code detects (timeouts, framing, bad arguments, I/O).

#include <string_view>
#include <system_error>
#include <type_traits>

#include <boost/system/error_code.hpp>

namespace gw::devices::ms2000 {

// ":N-1" .. ":N-6", ":N-21"; other codes are kept as they are and named "controller_error".
inline constexpr int unknown_command = -1;
inline constexpr int unrecognized_axis = -2;
inline constexpr int missing_parameters = -3;
inline constexpr int parameter_out_of_range = -4;
inline constexpr int operation_failed = -5;
inline constexpr int undefined_error = -6;
inline constexpr int halted = -21;

// A stable snake_case name for a controller code ("unknown_command"), "controller_error" if unknown.
std::string_view controller_error_name(int code);
// The manual's wording ("Unknown Command (Not Issued in MS-2000)"), "Unlisted controller error" if unknown.
std::string_view controller_error_description(int code);

enum class error {
    timeout = 1,          // no complete reply within the command's deadline
    unrecognized_reply,   // a line that fits no reply shape
    line_too_long,        // more bytes than max_line_bytes without CR LF
    controller_rejected,  // the controller answered ":N-<code>"
    invalid_argument,     // refused by the command builder before anything reached the wire
    queue_full,           // the controller's bounded command queue is full
    not_connected,        // the port is not open (yet, or any more)
    disconnected,         // the port went away while the command was in flight
    cancelled,            // the controller was stopped
    halted,               // a guarded command whose caller's HALT count is stale: a HALT came after it
    binary_reply,         // RDSBYTE typed where the answer must be text: it answers raw bytes
};

const boost::system::error_category& error_category() noexcept;
boost::system::error_code make_error_code(error e) noexcept;

}  // namespace gw::devices::ms2000

template <>
struct boost::system::is_error_code_enum<gw::devices::ms2000::error> : std::true_type {};
