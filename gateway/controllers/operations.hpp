#pragma once
// Typed operations on one controller: JSON-agnostic request structs, their results, and the pure
// planning step that validates a request against the controller's latest snapshot and builds the
// command(s) BEFORE anything goes on the wire. The controller_registry runs the plans.
//
// Validation order: controller connected -> firmware module present -> axes -> values. A missing
// module is operation_error_kind::missing_module, never a serial ":N-1".

#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/reply.hpp"
#include "devices/serial/controller_snapshot.hpp"
#include "gateway/common/operation_error.hpp"

namespace gw {

// Sanity bounds where the controller gives none.
inline constexpr double max_travel_um = 1e6;   // |position| of any axis: 1 m
inline constexpr double max_speed_mm_s = 50;   // fastest lead screw (D, 25.4 mm) is 26 mm/s
inline constexpr double max_dac_volts = 10;    // WRDAC 0..10 V
inline constexpr double max_led_percent = 99;  // LED X=0..99
inline constexpr std::chrono::milliseconds max_wait_timeout{10 * 60 * 1000};
inline constexpr std::chrono::milliseconds default_wait_timeout{60 * 1000};

struct axis_value_um {
    char axis = 'X';
    double micrometres = 0;
};

// "M X=.. Y=.." (absolute) or "R X=.." (relative), micrometres, any subset of the motor axes.
struct move_request {
    enum class mode { absolute, relative };
    mode kind = mode::absolute;
    std::vector<axis_value_um> axes;
    bool wait = false;  // complete only when the stage stopped (STATUS "N"), then read the positions
    std::chrono::milliseconds wait_timeout = default_wait_timeout;
    // Set by a caller that must not act after a HALT it did not see (a job's run): the controller's
    // halts_accepted() when it decided; the move, and its waits, fail with kind halted after a HALT.
    std::optional<std::uint64_t> halts_seen{};
};

struct move_result {
    bool waited = false;
    std::vector<axis_value_um> positions;  // when waited: "W <axes>" after the stage stopped
};

struct halt_request {};  // "\": sent whenever the port is open, identified or not
struct zero_request {};  // "Z": every axis's position becomes 0

struct home_request {
    std::string axes;  // "! X Y"; empty = every motor axis
};

struct here_request {  // "H X=.. Y=..": the current position is called this
    std::vector<axis_value_um> axes;
};

struct speed_request {  // "S X=mm/s"
    struct axis_speed {
        char axis = 'X';
        double mm_per_s = 0;
    };
    std::vector<axis_speed> axes;
};

struct ttl_request {  // "TTL X=<IN0 mode> Y=<OUT0 mode>"
    std::optional<int> in0_mode;
    std::optional<int> out0_mode;
    std::optional<bool> output_high;  // OUT0 held high (Y=1) or low (Y=0); excludes out0_mode
};

struct dac_request {  // "WRDAC X=volts" (DAC OUT module)
    double volts = 0;
};

struct led_request {  // "LED X=percent" (LED DIMMER module)
    double percent = 0;
    char channel = 'X';  // X, Y, Z or F
};

// CRISP focus lock (CRISP module): any of a new lock offset, a state change and saving, in that
// order; then every reading is read back. With `wait`, a lock completes once CRISP stopped trying
// (locked, or the error state when the sample is too far from focus).
struct crisp_request {
    enum class action : std::uint8_t { none, lock, unlock, off };
    action what = action::none;         // LK F=83 / 85 / 79
    std::optional<double> lock_offset;  // LK Z=<n>
    bool save = false;                  // SS Z: the settings survive a power cycle
    bool wait = false;                  // only with action::lock
    std::chrono::milliseconds wait_timeout = default_wait_timeout;
};

struct crisp_result {
    char state = 'I';                   // LK X?
    std::optional<double> focus_error;  // LK Y?
    std::optional<double> sum;          // LK T?
    std::optional<double> lock_offset;  // LK Z?
    std::optional<double> snr;          // EX Y? (EXTRA Y? before 9.53)
    std::chrono::microseconds latency{0};
};

// AUTOFOCUS (AUTOFOCUS module): a focus scan of Z; completes when it ended, with where Z stopped.
struct autofocus_request {
    std::chrono::milliseconds wait_timeout = default_wait_timeout;
};

struct autofocus_result {
    double z_um = 0;
    std::chrono::microseconds latency{0};
};

struct raw_command_request {  // one line typed by an expert: "W X Y"
    std::string command;
    std::optional<std::uint64_t> halts_seen{};  // as move_request::halts_seen
    // A command that resets or recalibrates the controller (ms2000::resets_or_recalibrates) is
    // refused without it; with it, the controller is identified again once it answered.
    bool force = false;
};

// A command the gateway built itself (a job's step): sent as it is, answered like a raw command.
struct command_request {
    devices::ms2000::command command;
    std::optional<std::uint64_t> halts_seen{};  // as move_request::halts_seen
};

// What every operation without a richer answer returns.
struct operation_done {
    std::chrono::microseconds latency{0};
};

struct raw_command_result {
    std::string raw_reply;         // the reply line as received
    devices::ms2000::reply reply;  // parsed; what == error for ":N-<code>" (not an operation_error)
    std::chrono::microseconds latency{0};
};

// Documented TTL modes (protocol doc §3.5).
bool is_documented_in0_mode(int mode);   // 0..12, 30
bool is_documented_out0_mode(int mode);  // 0, 1, 2, 9

// Pure planning: checks the request against `snapshot` and returns the command to send.
operation_result<devices::ms2000::command> plan(const move_request& r, const devices::controller_snapshot& s);
operation_result<devices::ms2000::command> plan(const halt_request& r, const devices::controller_snapshot& s);
operation_result<devices::ms2000::command> plan(const home_request& r, const devices::controller_snapshot& s);
operation_result<devices::ms2000::command> plan(const zero_request& r, const devices::controller_snapshot& s);
operation_result<devices::ms2000::command> plan(const here_request& r, const devices::controller_snapshot& s);
operation_result<devices::ms2000::command> plan(const speed_request& r,
                                                const devices::controller_snapshot& s);
operation_result<devices::ms2000::command> plan(const ttl_request& r, const devices::controller_snapshot& s);
operation_result<devices::ms2000::command> plan(const dac_request& r, const devices::controller_snapshot& s);
operation_result<devices::ms2000::command> plan(const led_request& r, const devices::controller_snapshot& s);
operation_result<devices::ms2000::command> plan(const command_request& r,
                                                const devices::controller_snapshot& s);
operation_result<devices::ms2000::command> plan(const raw_command_request& r,
                                                const devices::controller_snapshot& s);
// The writes of a CRISP request (possibly none: a read-out) and the read-out that follows them.
struct crisp_plan {
    std::vector<devices::ms2000::command> writes;
    std::vector<devices::ms2000::command> reads;  // LK X?, LK Y?, LK T?, LK Z? and, if known, the SNR
};
operation_result<crisp_plan> plan(const crisp_request& r, const devices::controller_snapshot& s);
operation_result<devices::ms2000::command> plan(const autofocus_request& r,
                                                const devices::controller_snapshot& s);

// The axes of a move in hardware order ("W" reads them back in this order).
std::string hardware_order(const std::vector<axis_value_um>& axes, const devices::controller_snapshot& s);

}  // namespace gw
