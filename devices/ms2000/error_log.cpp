#include "devices/ms2000/error_log.hpp"

#include <algorithm>
#include <charconv>

namespace gw::devices::ms2000 {

command read_error_log() {
    return raw_command("DU Y").value();
}

command clear_error_log() {
    return raw_command("DU X").value();
}

std::optional<std::vector<int>> error_log_codes(const reply& r) {
    if (r.what != reply::kind::ack || !r.axes.empty()) return std::nullopt;
    std::vector<int> codes;
    codes.reserve(r.values.size());
    for (const auto& v : r.values) {
        int code = -1;
        const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), code);
        if (ec != std::errc() || end != v.data() + v.size() || code < 0 || code > 9999) return std::nullopt;
        codes.push_back(code);
    }
    return codes;
}

std::string_view error_log_name(int code) {
    // The diagnostic list of the protocol reference (doc §2.2), 87 from seed 003.
    if (code >= 1 && code <= 9) return "OVERTIME";
    if (code >= 10 && code <= 12) return "OVERSHOT";
    if (code >= 20 && code <= 22) return "AXIS_DEAD";
    if (code >= 30 && code <= 32) return "EMERGENCY_STOP";
    switch (code) {
        case 34:
            return "UPPER_LIMIT";
        case 35:
            return "LOWER_LIMIT";
        case 85:
            return "SCAN_LOST_PULSES";
        case 86:
            return "SCAN_INCOMPLETE";
        case ttl_report_buffer_overrun:
            return "TTL_REPORT_BUFFER_OVERRUN";
        default:
            return "UNKNOWN";
    }
}

std::vector<int> new_error_log_codes(const std::vector<int>& seen, const std::vector<int>& now) {
    if (seen.size() <= now.size() && std::equal(seen.begin(), seen.end(), now.begin()))
        return {now.begin() + static_cast<std::ptrdiff_t>(seen.size()), now.end()};
    return now;
}

}  // namespace gw::devices::ms2000
