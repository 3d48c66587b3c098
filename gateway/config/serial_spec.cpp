#include "gateway/config/serial_spec.hpp"

#include <algorithm>
#include <charconv>
#include <iterator>

#include "gateway/config/config.hpp"

namespace gw {

namespace {
using spec_result = boost::system::result<devices::controller_settings, std::string>;

spec_result fail(const char* why) {
    return spec_result(boost::system::in_place_error, why);
}

}  // namespace

spec_result parse_serial_spec(std::string_view spec) {
    devices::controller_settings s;
    auto eq = spec.find('=');
    if (eq == std::string_view::npos) return fail("expected ID=PATH[@BAUD][,report=PATH]");
    s.id = std::string(spec.substr(0, eq));
    if (!is_valid_controller_id(s.id))
        return fail("the id must be 1-64 characters of letters, digits, '-' or '_'");
    std::string_view rest = spec.substr(eq + 1);

    if (auto comma = rest.find(','); comma != std::string_view::npos) {
        std::string_view option = rest.substr(comma + 1);
        rest = rest.substr(0, comma);
        constexpr std::string_view report_key = "report=";
        if (!option.starts_with(report_key) || option.size() == report_key.size()) {
            return fail("the only option after ',' is report=PATH");
        }
        s.report_port = std::string(option.substr(report_key.size()));
    }
    if (auto at = rest.rfind('@'); at != std::string_view::npos) {
        std::string_view baud = rest.substr(at + 1);
        unsigned value = 0;
        auto [end, ec] = std::from_chars(baud.data(), baud.data() + baud.size(), value);
        if (ec != std::errc() || end != baud.data() + baud.size() ||
            std::find(std::begin(supported_bauds), std::end(supported_bauds), value) ==
                std::end(supported_bauds)) {
            return fail("baud must be one of 9600, 19200, 28800, 38400, 57600, 115200");
        }
        s.baud = value;
        rest = rest.substr(0, at);
    }
    if (rest.empty()) return fail("the port path is empty");
    s.port = std::string(rest);
    return s;
}

}  // namespace gw
