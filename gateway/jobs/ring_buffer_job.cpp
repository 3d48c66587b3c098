// Placeholder until the ring_buffer job type lands: refuses every spec.
#include "gateway/jobs/job_kinds.hpp"

namespace gw::jobs {

operation_result<job_plan> plan_ring_buffer(const nlohmann::json&, const plan_context&) {
    return make_error(operation_error_kind::invalid_value, "job type ring_buffer is not implemented yet",
                      "type");
}

boost::asio::awaitable<void> run_ring_buffer(job_context&) {
    throw job_failure(
        make_error(operation_error_kind::internal, "job type ring_buffer is not implemented yet"));
    co_return;
}

}  // namespace gw::jobs
