#include "devices/serial/connection_problem.hpp"

#include <cerrno>
#include <system_error>

namespace gw::devices {

namespace {

constexpr std::string_view by_id_hint =
    "the adapter is unplugged, switched off or was renamed (ttyUSB numbers change between boots and "
    "replugs); name the port by its stable /dev/serial/by-id/ path ('asi-gateway ports' lists them)";
constexpr std::string_view by_id_unplugged_hint =
    "the adapter is unplugged or switched off (its /dev/serial/by-id/ link exists only while it is plugged "
    "in); 'asi-gateway ports' lists the ports there are";
constexpr std::string_view dialout_hint =
    "the gateway's user may not open the port: add it to the dialout group (usermod -aG dialout USER, "
    "then log in again; a systemd service needs SupplementaryGroups=dialout)";
constexpr std::string_view busy_hint =
    "another program has the port (a terminal program, ModemManager, a second gateway): close it or "
    "give this gateway another port";
constexpr std::string_view baud_hint =
    "check that the controller is switched on and cabled, and that the baud rate matches DIP switches "
    "4 and 5 ('asi-gateway ports' tries every MS-2000 rate)";

}  // namespace

connection_problem open_problem(std::string_view path, int err) {
    connection_problem p;
    p.text = "cannot open " + std::string(path) + ": " + std::generic_category().message(err);
    switch (err) {
        case ENOENT:
        case ENODEV:
        case ENXIO:
            p.name = "port_not_found";
            // A by-id link exists only while its adapter is plugged in: no advice to use one.
            p.hint = path.find("/serial/by-id/") != std::string_view::npos ? std::string(by_id_unplugged_hint)
                                                                           : std::string(by_id_hint);
            break;
        case EACCES:
        case EPERM:
            p.name = "permission_denied";
            p.hint = dialout_hint;
            break;
        case EBUSY:
        case EWOULDBLOCK:
            p.name = "port_busy";
            p.hint = busy_hint;
            break;
        case ENOTTY:
            p.name = "not_a_tty";
            p.hint = "the path is not a serial port; check the controller's port in the config";
            break;
        default:
            p.name = "open_failed";
            p.hint = "check the device and its driver (dmesg)";
            break;
    }
    return p;
}

connection_problem no_reply_problem(std::string_view path, std::string_view bauds) {
    return {"no_reply", "no reply on " + std::string(path) + " at " + std::string(bauds) + " baud",
            std::string(baud_hint)};
}

connection_problem not_ms2000_problem(std::string_view path, unsigned baud, std::string_view sample,
                                      std::string_view what) {
    std::string text = "the device on " + std::string(path) + " answers at " + std::to_string(baud) +
                       " baud, but not as an MS-2000";
    if (!what.empty()) text += " (" + std::string(what) + ")";
    if (!sample.empty()) text += ": \"" + std::string(sample) + "\"";
    return {"not_ms2000", std::move(text),
            "another device is on this port, or the baud rate does not match DIP switches 4 and 5 (at a "
            "wrong rate an MS-2000's answer arrives as noise)"};
}

}  // namespace gw::devices
