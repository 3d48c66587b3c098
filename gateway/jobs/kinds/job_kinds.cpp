#include "gateway/jobs/kinds/job_kinds.hpp"

#include <stdexcept>

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

}  // namespace

operation_result<job_plan> plan_job(job_type type, const nlohmann::json& spec, const plan_context& ctx) {
    operation_result<job_plan> plan = make_error(operation_error_kind::internal, "unknown job type");
    try {
        plan = plan_of_type(type, spec, ctx);
    } catch (const std::invalid_argument& e) {
        // A command the builder refuses (typed_command): a value the spec checks let through.
        return make_error(operation_error_kind::invalid_value, e.what(), "spec");
    }
    if (!plan) return plan;
    plan->type = type;
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
