#include "devices/sim/axis_motion.hpp"

#include <algorithm>
#include <cmath>

namespace gw::devices::sim {

namespace {
sim_time from_seconds(double s) {
    return sim_time{static_cast<long long>(std::llround(s * 1e6))};
}
}  // namespace

axis_motion::axis_motion(double from_mm, double to_mm, double speed_mm_s, double ramp_ms, double settle_ms,
                         sim_time start)
    : from_mm_(from_mm), to_mm_(to_mm), speed_(std::max(speed_mm_s, 1e-6)), start_(start) {
    const double d = std::abs(to_mm - from_mm);
    const double ramp = std::max(ramp_ms, 0.0) / 1000.0;
    if (d == 0) {
        total_s_ = 0;
    } else if (ramp <= 0) {
        total_s_ = d / speed_;
    } else {
        accel_ = speed_ / ramp;
        if (d >= speed_ * ramp) {
            ramp_s_ = ramp;
            total_s_ = d / speed_ + ramp;
        } else {
            ramp_s_ = std::sqrt(d / accel_);
            total_s_ = 2 * ramp_s_;
        }
    }
    motion_end_ = start + from_seconds(total_s_);
    // A zero-length move still settles (the controller checks the finish window), but briefly.
    settled_ = motion_end_ + from_seconds((d == 0 ? 0.1 : 1.0) * std::max(settle_ms, 0.0) / 1000.0);
}

double axis_motion::position_mm(sim_time now) const {
    if (now >= motion_end_) return to_mm_;
    if (now <= start_) return from_mm_;
    const double t = std::chrono::duration<double>(now - start_).count();
    const double d = std::abs(to_mm_ - from_mm_);
    double s = 0;
    if (accel_ <= 0) {
        s = speed_ * t;
    } else if (t < ramp_s_) {
        s = 0.5 * accel_ * t * t;
    } else if (t < total_s_ - ramp_s_) {
        s = 0.5 * accel_ * ramp_s_ * ramp_s_ + speed_ * (t - ramp_s_);
    } else {
        const double left = total_s_ - t;
        s = d - 0.5 * accel_ * left * left;
    }
    s = std::clamp(s, 0.0, d);
    return to_mm_ >= from_mm_ ? from_mm_ + s : from_mm_ - s;
}

bool axis_motion::ramping(sim_time now) const {
    if (!moving(now) || accel_ <= 0) return false;
    const double t = std::chrono::duration<double>(now - start_).count();
    return t < ramp_s_ || t > total_s_ - ramp_s_;
}

void axis_motion::stop(sim_time now) {
    const double here = position_mm(now);
    from_mm_ = here;
    to_mm_ = here;
    total_s_ = 0;
    start_ = now;
    motion_end_ = now;
    settled_ = now;
}

}  // namespace gw::devices::sim
