#pragma once
// Events a controller publishes besides its snapshot. Plain values.

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <boost/system/error_code.hpp>

namespace gw::devices {

// One encoder report frame from the TTL_REPORT module's SERIAL OUT port (one TTL trigger).
struct report_event {
    struct axis {
        char letter = 'X';
        std::int32_t counts = 0;
        std::optional<double> position_um;  // counts / counts_per_mm * 1000, if CNTS is known
    };
    std::string controller_id;
    std::uint64_t sequence = 0;  // 1, 2, 3 ... since the controller object was created
    std::chrono::steady_clock::time_point steady_time;
    std::chrono::system_clock::time_point system_time;
    std::vector<axis> axes;
    std::uint64_t bytes_skipped = 0;  // the decoder's running count of bytes that fit no frame
};

// An unsolicited serial position report on the main port (TTL IN0 mode 5 / RT M+):
// "T:   400    0.0    0.1".
struct ttl_event {
    struct axis {
        char letter = 'X';
        double position_um = 0;
    };
    std::string controller_id;
    std::uint64_t sequence = 0;
    std::chrono::steady_clock::time_point steady_time;
    std::chrono::system_clock::time_point system_time;
    double controller_ms = 0;  // the controller's own time stamp
    std::vector<axis> axes;    // letters assumed in hardware order (RM Y axis mask unknown to us)
};

// New codes in the controller's internal error log (DU Y), oldest first: diagnostics the firmware
// logged by itself (a move clamped at a limit: 34/35; an encoder report lost: 87).
struct error_log_event {
    std::string controller_id;
    std::vector<int> codes;
    std::chrono::system_clock::time_point system_time;  // when the log was read
};

// One finished command, user or internal (identify, poll).
struct command_trace {
    std::string controller_id;
    std::string request_id;  // as given to async_command; "poll" / "identify" for the driver's own
    bool internal = false;
    std::string wire;       // escaped: "W X Y Z\r"
    std::string raw_reply;  // escaped, empty if none arrived
    boost::system::error_code error;
    std::chrono::microseconds latency{0};  // write start to completion
};

// A fault on the main serial line that the driver handled: the link went out of step (a timeout, a
// reply that did not fit its command, noise, a reply nobody asked for), was resynchronised, or could
// not be and the connection was reset; or an observer or handler threw and was contained.
struct link_fault {
    enum class kind : std::uint8_t {
        timeout,        // no reply within the deadline
        mismatch,       // a reply of the wrong shape or content for its command
        noise,          // bytes that are not printable ASCII, or an overlong line
        unexpected,     // a line or bytes while no command was waiting for a reply
        resynced,       // the link was proven to be in step again
        resync_failed,  // it could not be: the connection was reset
        contained,      // an exception in the driver or an observer was caught
    };
    std::string controller_id;
    kind what = kind::timeout;
};

std::string_view to_string(link_fault::kind kind);

}  // namespace gw::devices
