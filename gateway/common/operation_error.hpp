#pragma once
// Why a typed operation on a controller failed. A plain value with a stable kind that the api layer
// maps to an HTTP status and a problem type; it knows nothing of HTTP itself.

#include <cstdint>
#include <string>
#include <string_view>

#include <boost/system/error_code.hpp>
#include <boost/system/result.hpp>

namespace gw {

enum class operation_error_kind : std::uint8_t {
    unknown_controller,  // no controller with that id (404)
    invalid_value,       // a value out of range or malformed; `field` names it (422)
    missing_module,      // the firmware build lacks the module the operation needs (409)
    busy,                // the stage is moving and the operation cannot run now (409)
    leased,              // another client holds the controller (409; used by jobs)
    not_connected,       // the controller is not connected or went away (503)
    timeout,             // the controller did not answer, or did not arrive in time (504)
    controller_error,    // the controller answered ":N-<code>" or an unparseable line (502)
    queue_full,          // the controller's command queue is full (503)
    unknown_job,         // no job with that id (404)
    invalid_state,       // the job (or lease) is not in a state that allows this: cancel a finished job (409)
    storage_unavailable,  // the job store cannot be written or read: disk full, read-only file (503)
    unknown_file,         // no uploaded G-code file with that id (404)
    halted,               // a HALT stopped it: a job's command after a HALT it did not see (409)
    job_active,           // a job runs on (or holds) the controller; its lease holder alone may (409)
    unknown_recording,    // no recording with that id (404)
    stale_command,        // an MQTT command that arrived after its deadline: not run (408)
    internal,             // a bug or an unexpected condition (500)
};

// Stable snake_case name ("missing_module"), for problem types, logs and metrics.
std::string_view to_string(operation_error_kind kind);

struct operation_error {
    operation_error_kind kind = operation_error_kind::internal;
    std::string message;               // for humans: "axis Q is not a motor axis of stage1 (X Y Z)"
    std::string field;                 // the offending request field ("axes.Q", "volts"), empty if none
    int controller_code = 0;           // controller_error: the signed ":N-<code>" (-4)
    std::string controller_code_name;  // controller_error: "parameter_out_of_range"

    bool operator==(const operation_error&) const = default;
};

operation_error make_error(operation_error_kind kind, std::string message, std::string field = {});
// A request field with a value the operation cannot take (invalid_value).
operation_error invalid_field(std::string field, std::string message);
// The error in words for a log line or a reason: its message, else its kind.
std::string describe(const operation_error& e);

// Maps a driver completion error (gw::devices::ms2000::error) to an operation error. `code` is the
// controller's ":N-<code>" when the error is controller_rejected.
operation_error from_driver_error(boost::system::error_code ec, int code, std::string_view controller_id);

template <typename T>
using operation_result = boost::system::result<T, operation_error>;

}  // namespace gw
