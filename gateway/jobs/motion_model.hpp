#pragma once
// Estimated duration of moves, from the same trapezoid-plus-settle model the simulator moves by
// (devices/ms2000/motion_profile.hpp): speed v (SPEED, mm/s), ramp time r (ACCEL, ms), settle time
// while the servo enters the finish-error window. Pure. The job planner sums these into ETAs.

#include <map>
#include <vector>

namespace gw::jobs {

struct axis_motion_params {
    double speed_mm_s = 1.0;  // the simulator's/firmware default lead screw speeds live in motion_model.cpp
    double ramp_ms = 100;
    double settle_ms = 0;
};

struct axis_delta_mm {
    char axis = 'X';
    double millimetres = 0;  // signed distance
};

class motion_model {
  public:
    motion_model() = default;
    explicit motion_model(std::map<char, axis_motion_params> axes) : axes_(std::move(axes)) {}

    // Axes not set explicitly use defaults for the standard 6.35 mm lead screw.
    const axis_motion_params& axis(char letter) const;
    void set_axis(char letter, axis_motion_params p) { axes_[letter] = p; }

    // Seconds for one move where every axis starts together ("M X= Y="): the slowest axis, including
    // its settle time. Zero-distance axes take no time.
    double move_seconds(const std::vector<axis_delta_mm>& deltas) const;
    // Seconds for one axis to travel `mm` at `speed_mm_s` (a scan line), ramps included, no settle.
    double travel_seconds(char axis, double mm, double speed_mm_s) const;

  private:
    std::map<char, axis_motion_params> axes_;
};

}  // namespace gw::jobs
