// parse_build_x() on arbitrary text; whatever it accepts must survive format_build_x() unchanged.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "devices/ms2000/build_info.hpp"

namespace ms2000 = gw::devices::ms2000;

namespace {

void check(bool condition) {
    if (!condition) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    const auto b = ms2000::parse_build_x(text);
    if (!b) return 0;
    check(!b->name.empty());
    check(b->ring_buffer_size > 0 || !b->has(ms2000::module::ring_buffer));
    const std::string formatted = ms2000::format_build_x(*b);
    check(formatted.find('\n') == std::string::npos);
    const auto again = ms2000::parse_build_x(formatted);
    check(again.has_value());
    check(again->name == b->name);
    check(again->motor_axes == b->motor_axes);
    check(again->command_axes == b->command_axes);
    check(again->bootloader == b->bootloader);
    check(again->hardware_revision == b->hardware_revision);
    check(again->module_lines == b->module_lines);
    check(again->modules == b->modules);
    check(again->ring_buffer_size == b->ring_buffer_size);
    check(ms2000::format_build_x(*again) == formatted);
    return 0;
}
