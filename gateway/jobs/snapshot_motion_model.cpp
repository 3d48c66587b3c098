#include "gateway/jobs/snapshot_motion_model.hpp"

#include <cmath>
#include <fmt/format.h>
#include <mutex>
#include <set>
#include <string>

#include <spdlog/logger.h>

#include "gateway/config/logging.hpp"

namespace gw::jobs {

namespace {

// Each fallback reason is logged once per process (controller, what), not on every submission.
void log_fallback_once(const std::string& controller, const std::string& what) {
    static std::mutex mutex;
    static std::set<std::string> logged;
    {
        std::lock_guard lock(mutex);
        if (!logged.insert(controller + "/" + what).second) return;
    }
    get_logger("jobs")->warn("motion model of {}: {}; estimates use the default", controller, what);
}

// A setting the controller answered with a usable value (> 0), or nullopt (logged once).
std::optional<double> positive(const std::string& controller, char axis, const char* verb,
                               std::optional<double> value) {
    if (value && *value > 0) return value;
    log_fallback_once(controller, value ? fmt::format("{} {}? is {}", verb, axis, *value)
                                        : fmt::format("{} {}? unanswered", verb, axis));
    return std::nullopt;
}

}  // namespace

motion_model motion_model_of(const devices::controller_snapshot& snapshot, std::optional<unsigned> baud) {
    motion_model model;
    const std::string& id = snapshot.id;
    for (const auto& a : snapshot.axes) {
        std::optional<lead_screw_motion> screw;
        if (a.counts_per_mm) screw = lead_screw_for_counts(*a.counts_per_mm);
        if (!screw) {
            log_fallback_once(
                id, a.counts_per_mm
                        ? fmt::format("lead screw of {}: unknown counts per mm {}", a.axis, *a.counts_per_mm)
                        : fmt::format("lead screw of {}: no counts per mm", a.axis));
            screw = default_lead_screw();
        }
        // ACCEL 0 would be no ramp at all; the firmware refuses it (range 1..), so it counts as unknown.
        const auto speed = positive(id, a.axis, "S", a.speed_mm_s);
        const auto ramp = positive(id, a.axis, "AC", a.ramp_ms);
        auto pc = a.finish_error_mm;
        // A finish error that prints as the screw's default (A: 0.0000055 mm prints "0.000005") is it.
        if (pc && std::abs(*pc - screw->default_pc_mm) <= a.finish_error_printed_step_mm)
            pc = screw->default_pc_mm;
        pc = positive(id, a.axis, "PC", pc);
        auto params = axis_params_for(*screw, speed, ramp, pc);
        params.backlash_mm = a.backlash_mm.value_or(0);
        params.overshoot_mm = a.overshoot_mm.value_or(0);
        params.lower_limit_mm = a.lower_limit_mm;
        params.upper_limit_mm = a.upper_limit_mm;
        model.set_axis(a.axis, params);
    }
    if (baud) {
        auto link = model.link();
        link.baud = *baud;
        model.set_link(link);
    }
    return model;
}

}  // namespace gw::jobs
