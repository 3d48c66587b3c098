#pragma once
// Reads a controller's motion parameters for the planner: "S X? Y? ..." (speed, mm/s), "AC X? Y? ..."
// (ramp time, ms), "PC X? ..." (finish error, mm: how long the servo settles), "B X? ..." and
// "OS X? ..." (backlash and overshoot, mm: a move's leg past its target) and the counts per mm in the
// snapshot (which lead screw). Missing answers fall back to motion_model's defaults, so a planner
// always gets a model; the reason for each fallback is logged once.

#include <functional>
#include <string>

#include "gateway/jobs/motion_model.hpp"

namespace gw {
class controller_registry;
}

namespace gw::jobs {

// `done` runs on the registry's executor with the model (never fails; see above).
void async_read_motion_model(controller_registry& registry, const std::string& controller_id,
                             const std::string& request_id, std::function<void(motion_model)> done);

}  // namespace gw::jobs
