#include "devices/ms2000/motion_profile.hpp"

#include <algorithm>
#include <cmath>

namespace gw::devices::ms2000 {

motion_profile::motion_profile(double distance_mm, double speed_mm_s, double ramp_ms)
    : distance_(std::abs(distance_mm)), speed_(std::max(speed_mm_s, 1e-6)) {
    const double ramp = std::max(ramp_ms, 0.0) / 1000.0;
    if (distance_ == 0) return;
    if (ramp <= 0) {
        total_s_ = distance_ / speed_;
        return;
    }
    accel_ = speed_ / ramp;
    if (distance_ >= speed_ * ramp) {
        ramp_s_ = ramp;
        total_s_ = distance_ / speed_ + ramp;
    } else {
        ramp_s_ = std::sqrt(distance_ / accel_);
        total_s_ = 2 * ramp_s_;
    }
}

double motion_profile::travelled_mm(double t) const {
    if (t >= total_s_) return distance_;
    if (t <= 0) return 0;
    double s = 0;
    if (accel_ <= 0) {
        s = speed_ * t;
    } else if (t < ramp_s_) {
        s = 0.5 * accel_ * t * t;
    } else if (t < total_s_ - ramp_s_) {
        s = 0.5 * accel_ * ramp_s_ * ramp_s_ + speed_ * (t - ramp_s_);
    } else {
        const double left = total_s_ - t;
        s = distance_ - 0.5 * accel_ * left * left;
    }
    return std::clamp(s, 0.0, distance_);
}

bool motion_profile::ramping(double t) const {
    if (t >= total_s_ || accel_ <= 0) return false;
    return t < ramp_s_ || t > total_s_ - ramp_s_;
}

double move_time_s(double distance_mm, double speed_mm_s, double ramp_ms) {
    return motion_profile(distance_mm, speed_mm_s, ramp_ms).total_s();
}

double settle_ms(double screw_settle_ms, double default_pc_mm, double pc_mm) {
    const double pc = std::max(pc_mm, 1e-9);
    return std::max(screw_settle_ms, 0.0) * std::clamp(std::sqrt(default_pc_mm / pc), 0.1, 3.0);
}

double approach_leg_mm(double distance_mm, double backlash_mm, double overshoot_mm) {
    if (distance_mm == 0) return 0;
    const double backlash = distance_mm < 0 ? std::max(backlash_mm, 0.0) : 0.0;
    return std::max(backlash, std::max(overshoot_mm, 0.0));
}

double approach_leg_within_mm(double distance_mm, double leg_mm, double target_mm, double lower_mm,
                              double upper_mm) {
    if (distance_mm == 0 || !(leg_mm > 0)) return 0;
    const double room = distance_mm < 0 ? target_mm - lower_mm : upper_mm - target_mm;
    return std::clamp(room, 0.0, leg_mm);
}

double move_with_approach_s(double distance_mm, double leg_mm, double speed_mm_s, double ramp_ms) {
    const double out = std::abs(distance_mm) + leg_mm;
    return move_time_s(out, speed_mm_s, ramp_ms) +
           (leg_mm > 0 ? move_time_s(leg_mm, speed_mm_s, ramp_ms) : 0);
}

double settle_after_move_ms(double distance_mm, double settle) {
    return (distance_mm == 0 ? zero_move_settle_fraction : 1.0) * std::max(settle, 0.0);
}

}  // namespace gw::devices::ms2000
