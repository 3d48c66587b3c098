#pragma once
// Z -> analog output voltage (WRDAC X=<volts>) in Z analog mode, as the Tracer section of the vendor
// document states it. Two rules that disagree in sign (the "sign quirk"):
//   standard piezo range (no SETLOW/SETUP limits): Z in -50..+50 um, V = 0.1 * Z + 5
//       -50 um -> 0 V, 0 -> 5 V, +50 um -> 10 V   (Equation 1; rising)
//   custom limits low..high (SETLOW/SETUP):        V = 10 * (high - Z) / (high - low)
//       low -> 10 V, high -> 0 V                   ("as Z increases from min to max, V decreases")
// Resolution: each rule is applied exactly where the document states it. Custom limits equal to the
// standard ones still follow the custom (falling) rule: the document's own SETLOW/SETUP example uses
// -50/+50 um and says V falls. Pure.

#include "gateway/gcode/gcode_options.hpp"

namespace gw::gcode {

struct analog_mapping {
    double low_um = -50;
    double high_um = 50;
    bool falling = false;  // custom limits: 10 V at low, 0 V at high
};

analog_mapping analog_mapping_for(const gcode_options& options);

// Volts for `z_um` (not clamped: outside the limits the result leaves 0..10 V).
double analog_volts(const analog_mapping& mapping, double z_um);

}  // namespace gw::gcode
