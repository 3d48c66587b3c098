#pragma once
// The MS-2000's point-to-point motion profile, shared by the simulator (devices/sim/axis_motion) and
// the gateway's duration estimates (gateway/jobs/motion_model), so both move by one formula. Pure.
//   speed v (SPEED, mm/s), ramp time r (ACCEL, ms): acceleration a = v / r.
//   long move  (d >= v*r):  t = d/v + r          (accelerate, cruise, decelerate)
//   short move (d <  v*r):  t = 2*sqrt(d/a)      (triangle, peak speed below v)
//   no ramp    (r <= 0):    t = d/v
// After the motion the servo settles into the finish-error window (PC): the axis is busy for the
// settle time but already at its target. A wider window settles sooner (seed: "Opening up the Finish
// Error to about 10 rotary encoder counts allows the move to complete quickly").

namespace gw::devices::ms2000 {

class motion_profile {
  public:
    motion_profile() = default;
    // A move over `distance_mm` (sign ignored) at `speed_mm_s` (clamped to >= 1e-6) with `ramp_ms`.
    motion_profile(double distance_mm, double speed_mm_s, double ramp_ms);

    double distance_mm() const { return distance_; }
    double speed_mm_s() const { return speed_; }
    double accel_mm_s2() const { return accel_; }  // 0: no ramp
    double ramp_s() const { return ramp_s_; }      // time spent accelerating (and again decelerating)
    double total_s() const { return total_s_; }    // motion time, settle excluded

    // Distance covered after `t_s` seconds (0 before the start, distance_mm() after the end).
    double travelled_mm(double t_s) const;
    // Accelerating or decelerating at `t_s`.
    bool ramping(double t_s) const;

  private:
    double distance_ = 0;
    double speed_ = 1;
    double accel_ = 0;
    double ramp_s_ = 0;
    double total_s_ = 0;
};

// Seconds for a move of `distance_mm` (motion only).
double move_time_s(double distance_mm, double speed_mm_s, double ramp_ms);

// Settle time (ms) of a lead screw whose calibrated settle is `screw_settle_ms` at the default finish
// error `default_pc_mm`, when the finish error is `pc_mm`:
//   screw_settle_ms * clamp(sqrt(default_pc_mm / pc_mm), 0.1, 3.0)
double settle_ms(double screw_settle_ms, double default_pc_mm, double pc_mm);

// A zero-length move still settles (the controller checks the finish window), but briefly: this
// fraction of the settle time.
inline constexpr double zero_move_settle_fraction = 0.1;

// Settle time (ms) after a move of `distance_mm` (the zero-length case above included).
double settle_after_move_ms(double distance_mm, double settle_ms);

// How far a point-to-point move of `distance_mm` (signed) runs past its target before it comes back
// to it (mm, >= 0). BACKLASH b: a move down goes b past, so the target is always approached moving
// up; OVERSHOOT o: every move goes o past. The larger applies. The direction BACKLASH acts in is our
// reading: the protocol reference (§3.2) gives none.
double approach_leg_mm(double distance_mm, double backlash_mm, double overshoot_mm);

// The leg of a move of `distance_mm` to `target_mm` shortened to the room left beyond the target in
// the direction of travel, between `lower_mm` and `upper_mm` (where motion ends: the soft limits or
// the limit switches). A move that ends at a limit has no leg: the stage cannot run past it.
double approach_leg_within_mm(double distance_mm, double leg_mm, double target_mm, double lower_mm,
                              double upper_mm);

// Motion time (settle excluded) of a point-to-point move with its approach leg: out past the target
// and back.
double move_with_approach_s(double distance_mm, double leg_mm, double speed_mm_s, double ramp_ms);

}  // namespace gw::devices::ms2000
