#include "devices/sim/axis_motion.hpp"

#include <cmath>

namespace gw::devices::sim {

namespace {
sim_time from_seconds(double s) {
    return sim_time{static_cast<long long>(std::llround(s * 1e6))};
}

double seconds(sim_time t) {
    return std::chrono::duration<double>(t).count();
}
}  // namespace

axis_motion::axis_motion(double from_mm, double to_mm, double speed_mm_s, double ramp_ms, double settle_ms,
                         sim_time start, double leg_mm)
    : from_mm_(from_mm),
      to_mm_(to_mm),
      profile_(std::abs(to_mm - from_mm) + leg_mm, speed_mm_s, ramp_ms),
      via_mm_(to_mm >= from_mm ? to_mm + leg_mm : to_mm - leg_mm),
      start_(start) {
    if (leg_mm > 0) back_profile_ = ms2000::motion_profile(leg_mm, speed_mm_s, ramp_ms);
    motion_end_ = start + from_seconds(profile_.total_s() + (leg_mm > 0 ? back_profile_.total_s() : 0));
    settled_ =
        motion_end_ + from_seconds(ms2000::settle_after_move_ms(profile_.distance_mm(), settle_ms) / 1000.0);
}

axis_motion axis_motion::at_velocity(double from_mm, double velocity_mm_s, double end_mm, sim_time start) {
    axis_motion m;
    m.from_mm_ = from_mm;
    m.to_mm_ = end_mm;
    m.via_mm_ = end_mm;
    m.velocity_mm_s_ = velocity_mm_s;
    m.start_ = start;
    const double distance = std::abs(end_mm - from_mm);
    m.motion_end_ = velocity_mm_s == 0 ? start : start + from_seconds(distance / std::abs(velocity_mm_s));
    m.settled_ = m.motion_end_;
    return m;
}

double axis_motion::position_mm(sim_time now) const {
    if (now >= motion_end_) return to_mm_;
    if (now <= start_) return from_mm_;
    if (velocity_mm_s_ != 0) return from_mm_ + velocity_mm_s_ * seconds(now - start_);
    const double t = seconds(now - start_);
    const bool up = via_mm_ >= from_mm_;
    if (t <= profile_.total_s()) {
        const double s = profile_.travelled_mm(t);
        return up ? from_mm_ + s : from_mm_ - s;
    }
    const double back = back_profile_.travelled_mm(t - profile_.total_s());  // past the target, back
    return up ? via_mm_ - back : via_mm_ + back;
}

bool axis_motion::ramping(sim_time now) const {
    if (!moving(now)) return false;
    return profile_.ramping(seconds(now - start_));
}

void axis_motion::stop(sim_time now) {
    const double here = position_mm(now);
    from_mm_ = here;
    to_mm_ = here;
    profile_ = ms2000::motion_profile{};
    back_profile_ = ms2000::motion_profile{};
    via_mm_ = here;
    velocity_mm_s_ = 0;
    start_ = now;
    motion_end_ = now;
    settled_ = now;
}

}  // namespace gw::devices::sim
