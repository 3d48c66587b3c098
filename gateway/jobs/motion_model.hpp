#pragma once
// Estimated duration of moves, from the same trapezoid-plus-settle model the simulator moves by
// (devices/ms2000/motion_profile.hpp): speed v (SPEED, mm/s), ramp time r (ACCEL, ms), settle time
// while the servo enters the finish-error window. Pure. The job planner sums these into ETAs.
//
// Defaults (an axis nobody set) are the simulator's default lead screw B (6.35 mm pitch): SPEED
// 5.5 mm/s, ACCEL 20 ms, settle 14 ms at the default finish error PC 0.000022 mm, top speed 6.8 mm/s.
// The values come from the simulator's lead-screw table (devices/sim/sim_config.hpp), so estimates
// and simulated moves cannot drift apart.

#include <map>
#include <optional>
#include <vector>

#include "devices/ms2000/host_step_timing.hpp"

namespace gw::jobs {

struct axis_motion_params {
    double speed_mm_s = 5.5;      // SPEED (S X?)
    double ramp_ms = 20;          // ACCEL (AC X?)
    double settle_ms = 14;        // after every move; from the lead screw and the finish error (PC X?)
    double max_speed_mm_s = 6.8;  // the lead screw's top speed (SCAN moves to a line start at it)
    double backlash_mm = 0;       // BACKLASH (B X?): a move down runs this far past and comes back
    double overshoot_mm = 0;      // OVERSHOOT (OS X?): every move runs this far past and comes back
    // Where the travel ends (SL X?, SU X?): the leg of a move that ends near them is shorter.
    std::optional<double> lower_limit_mm{};
    std::optional<double> upper_limit_mm{};
};

struct axis_delta_mm {
    axis_delta_mm() = default;
    axis_delta_mm(char a, double mm, std::optional<double> target = std::nullopt)
        : axis(a), millimetres(mm), target_mm(target) {}

    char axis = 'X';
    double millimetres = 0;           // signed distance
    std::optional<double> target_mm;  // where the move ends, when known: cuts the leg at a limit
};

// One row of the lead-screw table, as the motion model needs it.
struct lead_screw_motion {
    char id = 'B';
    double counts_per_mm = 45397.6;  // CNTS X?: tells the screws apart
    double default_speed_mm_s = 5.5;
    double max_speed_mm_s = 6.8;
    double settle_ms = 14;            // at the default finish error
    double default_pc_mm = 0.000022;  // default finish error = one encoder step
};

// The default screw (B) and the table's row whose counts per mm is within 1 % of `counts_per_mm`.
lead_screw_motion default_lead_screw();
std::optional<lead_screw_motion> lead_screw_for_counts(double counts_per_mm);

// The parameters of an axis on `screw` with SPEED/ACCEL/PC as given (nullopt: the firmware default:
// the screw's default speed, 20 ms, one encoder step). Settle = the simulator's scaling with PC.
axis_motion_params axis_params_for(const lead_screw_motion& screw, std::optional<double> speed_mm_s = {},
                                   std::optional<double> ramp_ms = {}, std::optional<double> pc_mm = {});

class motion_model {
  public:
    motion_model() = default;
    explicit motion_model(std::map<char, axis_motion_params> axes) : axes_(std::move(axes)) {}

    // Axes not set explicitly use defaults for the standard 6.35 mm lead screw.
    const axis_motion_params& axis(char letter) const;
    void set_axis(char letter, axis_motion_params p) { axes_[letter] = p; }
    const std::map<char, axis_motion_params>& axes() const { return axes_; }

    // The serial link and the host's STATUS polling (baud from the controller's settings): what a
    // host-driven step costs besides its motion (devices/ms2000/host_step_timing). Only the `gcode`
    // job, with a MOVE per short segment, adds it to its estimate; the other jobs' steps are long
    // enough for it not to matter (bench/RESULTS.md, job ETA).
    const devices::ms2000::host_link_timing& link() const { return link_; }
    void set_link(devices::ms2000::host_link_timing link) { link_ = link; }

    // Seconds for one move where every axis starts together ("M X= Y="): the slowest axis, including
    // its settle time. Zero-distance axes take no time (a move of nothing at all returns 0, although
    // the controller would settle for a tenth of the settle time if it were sent).
    double move_seconds(const std::vector<axis_delta_mm>& deltas) const;
    // Seconds for one axis to travel `mm` at `speed_mm_s` (a scan line), ramps included, no settle.
    double travel_seconds(char axis, double mm, double speed_mm_s) const;
    // Seconds for one axis to move `mm` at `speed_mm_s` (<= 0: its SPEED), settle included: what the
    // controller stays busy for (a SCAN line, retrace or start move at a given speed). A move at its
    // own SPEED is a point-to-point move and includes the BACKLASH / OVERSHOOT leg, as the controller
    // (and the simulator) runs it; one at a given speed does not.
    // With `target_mm`, the leg is cut to the room left before the axis's soft limit.
    double axis_move_seconds(char axis, double mm, double speed_mm_s = 0,
                             std::optional<double> target_mm = std::nullopt) const;

  private:
    std::map<char, axis_motion_params> axes_;
    devices::ms2000::host_link_timing link_;
};

}  // namespace gw::jobs
