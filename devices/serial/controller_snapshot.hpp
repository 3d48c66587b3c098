#pragma once
// The typed state of one controller as the driver last saw it. A plain value, copied to observers.

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "devices/ms2000/build_info.hpp"

namespace gw::devices {

enum class connection_state : std::uint8_t {
    stopped,       // stop() was called (or start() not yet)
    disconnected,  // the connection was lost; a reconnect is scheduled
    identifying,   // port open, V / BU X / CNTS ... in progress
    connected,     // identified; polling
    connecting,    // started; the first attempt to open the port is under way
    // An attempt to open or identify failed (last_error says why and what to do, next_retry when the
    // next attempt is due); the state stays so during later attempts until one succeeds.
    unreachable,
};
std::string_view to_string(connection_state s);

enum class report_port_state : std::uint8_t {
    none,    // no report port configured
    closed,  // configured but not open (controller not connected, or open failed)
    open,
};
std::string_view to_string(report_port_state s);

struct controller_identity {
    std::string version;      // "9.52" (parse_version), or the raw reply text if it has another form
    std::string version_raw;  // ":A Version: USB-9.52 "
    ms2000::build_info build;

    bool operator==(const controller_identity&) const = default;
};

struct axis_state {
    char axis = 'X';
    std::optional<double> position_um;     // from W, tenths of a micron / 10
    bool busy = false;                     // RS <axis>? while "/" says B
    std::optional<double> counts_per_mm;   // CNTS <axis>?
    std::optional<double> lower_limit_mm;  // SL <axis>?
    std::optional<double> upper_limit_mm;  // SU <axis>?
    // The motion settings a job's plan times its moves by, read at identification and again after a
    // command sets one (as the soft limits are), so a submission needs no serial round trip. Unset when
    // the controller did not answer.
    std::optional<double> speed_mm_s{};       // S <axis>?
    std::optional<double> ramp_ms{};          // AC <axis>?
    std::optional<double> finish_error_mm{};  // PC <axis>?
    double finish_error_printed_step_mm = 0;  // half the last digit PC printed ("0.000005": 5e-7)
    std::optional<double> backlash_mm{};      // B <axis>?
    std::optional<double> overshoot_mm{};     // OS <axis>?

    bool operator==(const axis_state&) const = default;
};

struct controller_error_info {
    int code = 0;      // the controller's signed code (-4) or 0 for a driver error
    std::string name;  // "parameter_out_of_range", "timeout"
    std::string text;  // human-readable; for a connection problem with the path and the errno text
    std::string hint;  // what a person can do about it (connection_problem.hpp), or empty
    std::chrono::system_clock::time_point when;

    bool operator==(const controller_error_info&) const = default;
};

// An emergency HALT latched by the gateway (gateway/controllers/controller_registry: never set by the
// driver): who stopped the stage and when. Jobs on the controller send nothing more, and queued ones do
// not start, until someone resumes or submits a job there.
struct halt_latch {
    std::string by;  // the caller's name ("ada", "anonymous", "mqtt:lab-3", "signal")
    std::chrono::system_clock::time_point at;

    bool operator==(const halt_latch&) const = default;
};

struct controller_snapshot {
    std::string id;
    connection_state state = connection_state::stopped;
    std::string port;
    std::optional<controller_identity> identity;
    std::vector<axis_state> axes;      // hardware order (BU X "Motor Axes:")
    bool busy = false;                 // STATUS "/"
    std::optional<int> ttl_in0_mode;   // TTL X?
    std::optional<int> ttl_out0_mode;  // TTL Y?
    // CRISP's state letter ("LK X?", ms2000/crisp.hpp), read in every poll round of a controller with
    // the CRISP module.
    std::optional<char> crisp_state;
    std::optional<controller_error_info> last_error;
    report_port_state report = report_port_state::none;
    // The controller's own error log (DU Y): the newest codes read (at most error_log_recent_limit,
    // oldest first) and how many have been read since the controller object was created.
    static constexpr std::size_t error_log_recent_limit = 16;
    std::vector<int> error_log_recent;
    std::uint64_t error_log_count = 0;
    // The start of the latest attempt to open and identify the port, and, while not connected, when
    // the next one is due (a replugged adapter is tried sooner).
    std::optional<std::chrono::system_clock::time_point> last_attempt;
    std::optional<std::chrono::system_clock::time_point> next_retry;
    std::chrono::system_clock::time_point updated;  // last time anything above changed or was polled
    // When the axes' positions were last read (W). A later change of the busy flags alone leaves it:
    // the positions are still those of that moment, not of `updated`.
    std::chrono::system_clock::time_point positions_read;
    std::optional<halt_latch> halted;

    const axis_state* axis(char letter) const;
    std::string motor_axes() const;  // the axes' letters in hardware order: "XYZ"
};

// True when everything but `updated` and `positions_read` is equal (snapshots are only published on a
// change).
bool same_content(const controller_snapshot& a, const controller_snapshot& b);

}  // namespace gw::devices
