// Placeholder until the scan job type lands: refuses every spec.
#include "gateway/jobs/job_kinds.hpp"

namespace gw::jobs {

operation_result<job_plan> plan_scan(const nlohmann::json&, const plan_context&) {
    return make_error(operation_error_kind::invalid_value, "job type scan is not implemented yet", "type");
}

boost::asio::awaitable<void> run_scan(job_context&) {
    throw job_failure(make_error(operation_error_kind::internal, "job type scan is not implemented yet"));
    co_return;
}

}  // namespace gw::jobs
