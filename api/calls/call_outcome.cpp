#include "api/calls/call_outcome.hpp"

namespace gw::api {

api_outcome failed(problem p, const std::string& request_id) {
    p.request_id = request_id;
    api_outcome out;
    out.status = p.status;
    out.error = std::move(p);
    return out;
}

api_outcome failed(const operation_error& e, const std::string& request_id) {
    return failed(make_problem(e), request_id);
}

}  // namespace gw::api
