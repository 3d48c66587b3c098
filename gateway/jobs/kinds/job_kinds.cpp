#include "gateway/jobs/kinds/job_kinds.hpp"

#include <fmt/format.h>
#include <stdexcept>

#include "gateway/jobs/job_commands.hpp"
#include "gateway/jobs/kinds/spec_fields.hpp"

namespace gw::jobs {

namespace {

operation_result<job_plan> plan_of_type(job_type type, const nlohmann::json& spec, const plan_context& ctx) {
    operation_result<job_plan> plan = make_error(operation_error_kind::internal, "unknown job type");
    switch (type) {
        case job_type::array:
            plan = plan_array(spec, ctx);
            break;
        case job_type::scan:
            plan = plan_scan(spec, ctx);
            break;
        case job_type::ring_buffer:
            plan = plan_ring_buffer(spec, ctx);
            break;
        case job_type::planar_correction:
            plan = plan_planar_correction(spec, ctx);
            break;
        case job_type::gcode:
            plan = plan_gcode(spec, ctx);
            break;
    }
    return plan;
}

// spec.record, checked before the type's own fields (which leave it to this).
operation_result<bool> record_flag(job_type type, const nlohmann::json& spec,
                                   const devices::controller_snapshot& s) {
    if (!spec.is_object() || !spec.contains("record")) return false;
    const auto& v = spec["record"];
    if (!v.is_boolean()) return spec_error("record", "record must be true or false");
    if (!v.get<bool>()) return false;
    if (type == job_type::planar_correction)
        return spec_error(
            "record",
            "a planar correction triggers no frames: record applies to array, scan, ring_buffer "
            "and gcode jobs");
    if (s.report == devices::report_port_state::none)
        return spec_error("record", fmt::format("{} has no report port: configure its report_port (the "
                                                "TTL_REPORT module's SERIAL OUT) to record",
                                                s.id));
    return true;
}

// A recording run sets the trigger input when it is off (TTL X=1: any non-zero mode makes the report
// module send a frame at each edge) and puts it back after.
void add_recording(job_plan& plan, const devices::controller_snapshot& s) {
    plan.record = true;
    plan.summary +=
        plan.summary.empty() ? "records each trigger's positions" : "; records each trigger's positions";
    if (s.ttl_in0_mode.value_or(0) != 0) return;
    plan.commands.insert(plan.commands.begin(), ttl_in0_command(1));
    add_preview_command(plan, ttl_in0_command(0));
}

}  // namespace

operation_result<job_plan> plan_job(job_type type, const nlohmann::json& spec, const plan_context& ctx) {
    auto record = record_flag(type, spec, ctx.snapshot);
    if (!record) return record.error();
    operation_result<job_plan> plan = make_error(operation_error_kind::internal, "unknown job type");
    try {
        plan = plan_of_type(type, spec, ctx);
    } catch (const std::invalid_argument& e) {
        // A command the builder refuses (typed_command): a value the spec checks let through.
        return make_error(operation_error_kind::invalid_value, e.what(), "spec");
    }
    if (!plan) return plan;
    plan->type = type;
    if (*record) add_recording(*plan, ctx.snapshot);
    if (auto limits = check_soft_limits(*plan, ctx.snapshot); !limits) return limits.error();
    return plan;
}

boost::asio::awaitable<void> run_job(job_context& ctx) {
    switch (ctx.job().type) {
        case job_type::array:
            co_await run_array(ctx);
            break;
        case job_type::scan:
            co_await run_scan(ctx);
            break;
        case job_type::ring_buffer:
            co_await run_ring_buffer(ctx);
            break;
        case job_type::planar_correction:
            co_await run_planar_correction(ctx);
            break;
        case job_type::gcode:
            co_await run_gcode(ctx);
            break;
    }
}

}  // namespace gw::jobs
