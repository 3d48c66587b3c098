#pragma once
// The spec of a `scan` job (openapi/openapi.yaml, schema ScanSpec), parsed strictly, and the scan geometry
// the SCAN module would compute from it (seed 000, SCAN MODULE). Pure.
//
// Firmware validation (seed: "SCANR X=0.0 Y=1.0 Z=24 ... will generate a scan line with 1891 pixels,
// determined by multiplying the encoder resolution by the length of the scan and dividing by the
// encoder_divide parameter"; "The encoder-divide parameter and the total number of pixels per scan
// line must be less than 32768"): pixels = (whole encoder counts over the line) / divide, where the
// encoder resolution is CNTS (45396 counts/mm on a 6.35 mm screw, quadrature edges included: the
// seed's 1891 = 45396 x 1 mm / 24, not divided by 4). Both paths apply it, so a spec means the same
// on a controller with or without the module.

#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "gateway/common/operation_error.hpp"

namespace gw::jobs {

inline constexpr int scan_firmware_limit = 32768;  // divide and pixels must be below this
inline constexpr double max_scan_extent_mm = 1000;

struct scan_spec {
    enum class path_mode : std::uint8_t { automatic, firmware, host };

    char fast_axis = 'X';
    char slow_axis = 'Y';
    double fast_start_mm = 0;
    std::optional<double> fast_stop_mm;  // exactly one of fast_stop_mm and pixels
    std::optional<int> pixels;
    int encoder_divide = 24;
    double slow_start_mm = 0;
    double slow_stop_mm = 0;
    int lines = 1;
    bool serpentine = false;
    std::optional<double> speed_mm_s;  // empty: the axis's current SPEED
    path_mode mode = path_mode::automatic;
};

// What the firmware derives from SCANR/SCANV: the pixel count and both axes' line geometry.
struct scan_geometry {
    double counts_per_mm = 0;
    long long line_counts = 0;  // whole encoder counts over one line
    int pixels = 0;
    double fast_start_mm = 0, fast_stop_mm = 0;
    double slow_start_mm = 0, slow_stop_mm = 0;
    int lines = 1;
    bool serpentine = false;

    double line_length_mm() const;
    double slow_step_mm() const;  // slow-axis distance between lines (0 for one line)
    double slow_at(int line) const;
    // Where line `line` (0-based) starts and ends on the fast axis (serpentine reverses odd lines).
    double fast_begin(int line) const;
    double fast_end(int line) const;
};

operation_result<scan_spec> parse_scan_spec(const nlohmann::json& spec);

// invalid_value naming spec.fast.encoder_divide / spec.fast.stop_mm / spec.fast.pixels when the SCAN
// module would refuse the parameters.
operation_result<scan_geometry> scan_firmware_geometry(const scan_spec& spec, double counts_per_mm);

}  // namespace gw::jobs
