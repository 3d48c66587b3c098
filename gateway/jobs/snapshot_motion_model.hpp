#pragma once
// The planner's motion model of a controller, from its snapshot: the motion settings the driver read
// at identification and after every command that set one (SPEED, ACCEL, finish error PC, BACKLASH,
// OVERSHOOT), the counts per mm (which lead screw) and the soft limits. No serial round trip: a
// submission plans from what the gateway already knows. Missing values fall back to motion_model's
// defaults, so a planner always gets a model; the reason for each fallback is logged once.

#include <optional>

#include "devices/serial/controller_snapshot.hpp"
#include "gateway/jobs/motion_model.hpp"

namespace gw::jobs {

// `baud`: the serial link's rate (the controller's settings), for a host-driven step's link time.
motion_model motion_model_of(const devices::controller_snapshot& snapshot, std::optional<unsigned> baud);

}  // namespace gw::jobs
