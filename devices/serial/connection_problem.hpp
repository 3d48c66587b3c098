#pragma once
// Why a controller cannot be reached, said so that a person can act on it: a stable name, the text
// (with the path and the errno text) and a hint. Pure. Used by the driver for its last_error and log
// while it retries, and by the port probe for its report, so both give the same advice.
//   open_problem("/dev/ttyUSB0", ENOENT) ->
//     {"port_not_found", "cannot open /dev/ttyUSB0: No such file or directory",
//      "the adapter is unplugged, switched off or was renamed; ... /dev/serial/by-id/ ..."}

#include <string>
#include <string_view>

namespace gw::devices {

struct connection_problem {
    // port_not_found, permission_denied, port_busy, not_a_tty, open_failed, no_reply, not_ms2000
    std::string name;
    std::string text;
    std::string hint;
};

// open(2), the lock or the tty setup failed with `err` (an errno value).
connection_problem open_problem(std::string_view path, int err);

// The port opened but nothing came back to V at `bauds` ("9600", or "115200, 9600, 19200" for a probe).
connection_problem no_reply_problem(std::string_view path, std::string_view bauds);

// Bytes came back at `baud`, but no MS-2000 answer; `sample` is what came (escaped, printable) and
// `what` an optional verdict ("an ASI Tiger controller").
connection_problem not_ms2000_problem(std::string_view path, unsigned baud, std::string_view sample,
                                      std::string_view what = {});

}  // namespace gw::devices
