#pragma once
// Probes one serial port for an MS-2000, blocking (call it from a worker thread, never from an I/O
// thread). Sends only the harmless identification queries V and, once V was answered as an MS-2000
// answers, BU X; never a motion or settings command. Leaves a port alone that another program holds
// (a flock lock, exclusive mode, a UUCP lock file, or `held_by` from port_lock's open-file check) and
// restores the port's termios settings afterwards.
//
// Per baud rate (115200 first, then 9600, 19200, 28800, 38400, 57600): a CR ends whatever noise the
// controller collected at the previous rate, input is dropped, then V; the first answer that is an
// MS-2000's ends the probe. At a wrong rate the controller receives noise, as with any auto-baud
// detection (Micro-Manager's does the same); `bauds` may be narrowed to the one rate that is known.

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "devices/ms2000/build_info.hpp"

namespace gw::devices {

struct probe_settings {
    std::vector<unsigned> bauds{115200, 9600, 19200, 28800, 38400, 57600};
    std::chrono::milliseconds answer_timeout{200};  // per rate, for V (its answer is 25 bytes)
    std::chrono::milliseconds settle{30};           // after the CR, before V
    std::chrono::milliseconds build_timeout{1500};  // BU X, once V was answered
};

struct port_report {
    enum class status : std::uint8_t {
        ms2000,             // an MS-2000 answered: baud, version, build
        not_ms2000,         // something answered, but not as an MS-2000 (text has a sample)
        no_answer,          // opened, nothing came back at any rate
        busy,               // another program holds it (text says how)
        permission_denied,  // EACCES: not in the dialout group
        not_found,          // no such node (a dangling by-id link, a given path that is gone)
        not_a_tty,          // a path that is not a serial port: nothing was written
        in_use,             // one of this gateway's controllers has it: not probed
        error,              // any other failure (text)
    };
    status what = status::error;
    std::string path;         // as listed: the by-id link, or the node
    std::string device;       // the node it resolves to ("/dev/ttyUSB0"), empty if it does not resolve
    unsigned baud = 0;        // ms2000: the rate that answered; not_ms2000: the rate of the sample
    std::string version;      // ms2000: "9.52"
    std::string version_raw;  // ms2000: the V answer line, escaped
    std::optional<ms2000::build_info> build;  // ms2000, when BU X was answered
    std::string controller;                   // in_use: the controller id
    std::string text;                         // what happened, with the path (escaped controller bytes only)
    std::string hint;                         // what to do about it (connection_problem)
};

std::string_view to_string(port_report::status s);

// `held_by` (from port_lock.hpp's open_elsewhere): when set, the port is reported busy unopened.
port_report probe_port(const std::string& path, const probe_settings& settings,
                       const std::string& held_by = {});

}  // namespace gw::devices
