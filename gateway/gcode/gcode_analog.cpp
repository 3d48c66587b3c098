#include "gateway/gcode/gcode_analog.hpp"

namespace gw::gcode {

analog_mapping analog_mapping_for(const gcode_options& options) {
    if (options.analog_low_um && options.analog_high_um)
        return analog_mapping{*options.analog_low_um, *options.analog_high_um, true};
    return analog_mapping{};
}

double analog_volts(const analog_mapping& m, double z_um) {
    if (m.falling) return 10 * (m.high_um - z_um) / (m.high_um - m.low_um);
    return 0.1 * z_um + 5;
}

}  // namespace gw::gcode
