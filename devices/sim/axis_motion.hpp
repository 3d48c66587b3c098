#pragma once
// Trapezoidal motion of one axis in simulated time. Pure: the caller passes the time in. The profile
// (trapezoid or triangle, then settle) is devices/ms2000/motion_profile.hpp, the same formula the
// gateway's duration estimates use; the axis is busy until the settle time is over but is already at
// its target. Calibrated against the seed's "Stage Scanning Speed and Accuracy" table (see
// sim_config.cpp and tests/unit/sim/calibration_test.cpp).

#include <chrono>

#include "devices/ms2000/motion_profile.hpp"

namespace gw::devices::sim {

using sim_time = std::chrono::microseconds;

class axis_motion {
  public:
    axis_motion() = default;
    // A move from `from_mm` to `to_mm` starting at `start`; with `leg_mm` > 0 it runs that far past
    // the target and comes back (BACKLASH, OVERSHOOT: ms2000::approach_leg_mm), then settles.
    axis_motion(double from_mm, double to_mm, double speed_mm_s, double ramp_ms, double settle_ms,
                sim_time start, double leg_mm = 0);
    // Constant velocity (SPIN, VECTOR) from `from_mm` until `end_mm` (the limit ahead) or stop().
    static axis_motion at_velocity(double from_mm, double velocity_mm_s, double end_mm, sim_time start);

    double position_mm(sim_time now) const;
    bool moving(sim_time now) const { return now < motion_end_; }  // motor running
    bool busy(sim_time now) const { return now < settled_; }       // includes settle time
    bool ramping(sim_time now) const;
    sim_time start() const { return start_; }
    sim_time motion_end() const { return motion_end_; }
    sim_time settled() const { return settled_; }
    double target_mm() const { return to_mm_; }
    double from_mm() const { return from_mm_; }
    double velocity_mm_s() const { return velocity_mm_s_; }  // non-zero for SPIN/VECTOR motion

    // Stops at the current position (HALT): no further motion, not busy.
    void stop(sim_time now);

  private:
    double from_mm_ = 0;
    double to_mm_ = 0;
    ms2000::motion_profile profile_;       // out: to the target, or past it by the leg
    ms2000::motion_profile back_profile_;  // back from past the target (a zero profile: no leg)
    double via_mm_ = 0;                    // where the outward motion turns (the target without a leg)
    sim_time start_{0};
    sim_time motion_end_{0};
    sim_time settled_{0};
    double velocity_mm_s_ = 0;
};

}  // namespace gw::devices::sim
