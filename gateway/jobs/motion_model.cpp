// Placeholder until the shared motion profile lands: a plain trapezoid with the default screw.
#include "gateway/jobs/motion_model.hpp"

#include <algorithm>
#include <cmath>

namespace gw::jobs {

const axis_motion_params& motion_model::axis(char letter) const {
    static const axis_motion_params defaults{};
    auto it = axes_.find(letter);
    return it == axes_.end() ? defaults : it->second;
}

double motion_model::travel_seconds(char axis_letter, double mm, double speed_mm_s) const {
    const auto& p = axis(axis_letter);
    const double d = std::abs(mm);
    if (d == 0 || speed_mm_s <= 0) return 0;
    const double ramp_s = p.ramp_ms / 1000.0;
    if (ramp_s <= 0) return d / speed_mm_s;
    const double accel = speed_mm_s / ramp_s;
    if (d >= speed_mm_s * ramp_s) return d / speed_mm_s + ramp_s;
    return 2 * std::sqrt(d / accel);
}

double motion_model::move_seconds(const std::vector<axis_delta_mm>& deltas) const {
    double slowest = 0;
    for (const auto& d : deltas) {
        if (d.millimetres == 0) continue;
        const auto& p = axis(d.axis);
        slowest =
            std::max(slowest, travel_seconds(d.axis, d.millimetres, p.speed_mm_s) + p.settle_ms / 1000.0);
    }
    return slowest;
}

}  // namespace gw::jobs
