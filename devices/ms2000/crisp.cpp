#include "devices/ms2000/crisp.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <string>

namespace gw::devices::ms2000 {

std::string_view crisp_state_name(char state) {
    // The state letters MM-Stage maps (ASICRISP.cpp, doc §3.12).
    switch (state) {
        case 'I':
            return "idle";
        case 'R':
            return "ready";
        case 'D':
            return "dim";
        case 'K':
            return "trying_to_lock";
        case 'F':
            return "locked";
        case 'N':
            return "inhibit";
        case 'E':
            return "error";
        case 'G':
            return "log_amp_calibration";
        case 'o':
        case 'l':
            return "resetting_offset";
        case 'f':
            return "dither";
        case 'B':
            return "balance";
        default:
            break;
    }
    if (state == 'H' || state == 'C' || (state >= '1' && state <= '5') || (state >= 'g' && state <= 'j') ||
        state == 't')
        return "calibrating";
    if (state >= 'a' && state <= 'e') return "focus_curve";
    return "unknown";
}

bool crisp_locking_or_locked(char state) {
    return state == 'F' || state == 'K';
}

command crisp_state_query() {
    return raw_command("LK X?").value();
}
command crisp_focus_error_query() {
    return raw_command("LK Y?").value();
}
command crisp_sum_query() {
    return raw_command("LK T?").value();
}
command crisp_offset_query() {
    return raw_command("LK Z?").value();
}
command crisp_lock() {
    return raw_command("LK F=83").value();
}
command crisp_unlock() {
    return raw_command("LK F=85").value();
}
command crisp_off() {
    return raw_command("LK F=79").value();
}

boost::system::result<command> crisp_set_offset(double offset) {
    if (!std::isfinite(offset) || std::abs(offset) > max_crisp_offset)
        return boost::system::errc::make_error_code(boost::system::errc::invalid_argument);
    const argument arg{'Z', argument::op::set, offset, 1};
    return make_command("LK", std::span<const argument>(&arg, 1));
}

std::optional<command> crisp_snr_query(std::string_view firmware_version) {
    // "9.53" -> 9 and 53; letter revisions ("9.2m") are older than 9.50.
    const auto dot = firmware_version.find('.');
    if (dot == std::string_view::npos) return std::nullopt;
    int major = 0, minor = 0;
    const auto* first = firmware_version.data();
    const auto* end = first + firmware_version.size();
    if (std::from_chars(first, first + dot, major).ec != std::errc()) return std::nullopt;
    const auto [after, ec] = std::from_chars(first + dot + 1, end, minor);
    if (ec != std::errc() || after == first + dot + 1) return std::nullopt;
    const bool two_digits = after - (first + dot + 1) >= 2;
    const bool new_enough = major > 9 || (major == 9 && two_digits && minor >= 53);
    return raw_command(new_enough ? "EX Y?" : "EXTRA Y?").value();
}

command autofocus_start() {
    return raw_command("AF").value();
}
command autofocus_query() {
    return raw_command("AF X?").value();
}

std::optional<char> crisp_state_of(const reply& r) {
    if (r.what != reply::kind::ack || !r.axes.empty() || r.values.size() != 1 || r.values[0].size() != 1)
        return std::nullopt;
    const char c = r.values[0][0];
    if (!std::isalnum(static_cast<unsigned char>(c))) return std::nullopt;
    return c;
}

std::optional<double> single_reading(const reply& r) {
    if (r.what != reply::kind::ack) return std::nullopt;
    std::optional<double> v;
    if (r.values.size() == 1 && r.axes.empty()) v = r.number(0);
    if (r.axes.size() == 1 && r.values.empty()) v = r.axes[0].number;
    if (v && !std::isfinite(*v)) return std::nullopt;  // "inf" is text, not a reading
    return v;
}

}  // namespace gw::devices::ms2000
