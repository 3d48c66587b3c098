#include "gateway/jobs/job_plan.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "gateway/controllers/operations.hpp"

namespace gw::jobs {

void bounding_box::include(const position_um& p) {
    for (const auto& [axis, um] : p) {
        auto lo = min.try_emplace(axis, um).first;
        auto hi = max.try_emplace(axis, um).first;
        lo->second = std::min(lo->second, um);
        hi->second = std::max(hi->second, um);
    }
}

void add_preview_command(job_plan& plan, std::string command) {
    if (plan.commands.size() < max_preview_commands)
        plan.commands.push_back(std::move(command));
    else
        ++plan.commands_omitted;
}

namespace {

std::string describe(const plan_step& step, std::size_t index) {
    return step.name.empty() ? "step " + std::to_string(index + 1) : step.name;
}

}  // namespace

operation_result<void> check_soft_limits(const job_plan& plan, const devices::controller_snapshot& s) {
    for (std::size_t i = 0; i < plan.steps.size(); ++i) {
        const auto& step = plan.steps[i];
        if (!step.target) continue;
        for (const auto& [axis, um] : *step.target) {
            const std::string field = "spec.steps[" + std::to_string(i) + "]";
            if (!std::isfinite(um) || std::abs(um) > max_travel_um)
                return make_error(operation_error_kind::invalid_value,
                                  fmt::format("{}: {}={:.1f} um is beyond the travel range (+-{:.0f} um)",
                                              describe(step, i), axis, um, max_travel_um),
                                  field);
            const auto* a = s.axis(axis);
            if (a == nullptr) continue;  // the planner checks axes; limits only where known
            if (a->lower_limit_mm && um < *a->lower_limit_mm * 1000.0)
                return make_error(operation_error_kind::invalid_value,
                                  fmt::format("{}: {}={:.1f} um is beyond the lower soft limit {} mm",
                                              describe(step, i), axis, um, *a->lower_limit_mm),
                                  field);
            if (a->upper_limit_mm && um > *a->upper_limit_mm * 1000.0)
                return make_error(operation_error_kind::invalid_value,
                                  fmt::format("{}: {}={:.1f} um is beyond the upper soft limit {} mm",
                                              describe(step, i), axis, um, *a->upper_limit_mm),
                                  field);
        }
    }
    return {};
}

double remaining_from(const job_plan& plan, std::size_t first) {
    double s = 0;
    for (std::size_t i = first; i < plan.steps.size(); ++i)
        s += plan.steps[i].estimated_s;
    return s;
}

}  // namespace gw::jobs
