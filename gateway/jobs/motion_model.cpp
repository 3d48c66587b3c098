#include "gateway/jobs/motion_model.hpp"

#include <algorithm>
#include <cmath>

#include "devices/ms2000/motion_profile.hpp"
#include "devices/sim/sim_config.hpp"

namespace gw::jobs {

namespace {

// The simulator's default ACCEL (ms2000_model.cpp), which is also the firmware's usual ramp.
constexpr double default_ramp_ms = 20;

lead_screw_motion from_sim(const devices::sim::lead_screw& s) {
    return {s.id, s.counts_per_mm, s.default_speed_mm_s, s.max_speed_mm_s, s.settle_ms, s.encoder_nm / 1e6};
}

}  // namespace

lead_screw_motion default_lead_screw() {
    return from_sim(devices::sim::lead_screw_for(devices::sim::sim_config{}.lead_screw).value());
}

std::optional<lead_screw_motion> lead_screw_for_counts(double counts_per_mm) {
    if (!(counts_per_mm > 0)) return std::nullopt;
    for (const char id : {'A', 'B', 'C', 'D'}) {
        const auto s = devices::sim::lead_screw_for(id);
        if (s && std::abs(s->counts_per_mm - counts_per_mm) <= 0.01 * s->counts_per_mm) return from_sim(*s);
    }
    return std::nullopt;
}

axis_motion_params axis_params_for(const lead_screw_motion& screw, std::optional<double> speed_mm_s,
                                   std::optional<double> ramp_ms, std::optional<double> pc_mm) {
    axis_motion_params p;
    p.speed_mm_s = std::min(speed_mm_s.value_or(screw.default_speed_mm_s), screw.max_speed_mm_s);
    p.ramp_ms = ramp_ms.value_or(default_ramp_ms);
    p.settle_ms =
        devices::ms2000::settle_ms(screw.settle_ms, screw.default_pc_mm, pc_mm.value_or(screw.default_pc_mm));
    p.max_speed_mm_s = screw.max_speed_mm_s;
    return p;
}

const axis_motion_params& motion_model::axis(char letter) const {
    static const axis_motion_params defaults = axis_params_for(default_lead_screw());
    auto it = axes_.find(letter);
    return it == axes_.end() ? defaults : it->second;
}

double motion_model::travel_seconds(char axis_letter, double mm, double speed_mm_s) const {
    if (mm == 0 || !(speed_mm_s > 0)) return 0;
    return devices::ms2000::move_time_s(mm, speed_mm_s, axis(axis_letter).ramp_ms);
}

double motion_model::axis_move_seconds(char axis_letter, double mm, double speed_mm_s,
                                       std::optional<double> target_mm) const {
    if (mm == 0) return 0;
    const auto& p = axis(axis_letter);
    const double v = speed_mm_s > 0 ? speed_mm_s : p.speed_mm_s;
    double leg = speed_mm_s > 0 ? 0 : devices::ms2000::approach_leg_mm(mm, p.backlash_mm, p.overshoot_mm);
    if (leg > 0 && target_mm) {
        constexpr double unlimited = 1e9;
        leg = devices::ms2000::approach_leg_within_mm(
            mm, leg, *target_mm, p.lower_limit_mm.value_or(-unlimited), p.upper_limit_mm.value_or(unlimited));
    }
    return devices::ms2000::move_with_approach_s(mm, leg, v, p.ramp_ms) +
           devices::ms2000::settle_after_move_ms(mm, p.settle_ms) / 1000.0;
}

double motion_model::move_seconds(const std::vector<axis_delta_mm>& deltas) const {
    double slowest = 0;
    for (const auto& d : deltas)
        slowest = std::max(slowest, axis_move_seconds(d.axis, d.millimetres, 0, d.target_mm));
    return slowest;
}

}  // namespace gw::jobs
