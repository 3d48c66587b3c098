#include "api/common/problem_response.hpp"

#include "gateway/common/json_text.hpp"

namespace gw::api {

std::string_view target_path(std::string_view target) {
    return target.substr(0, target.find('?'));
}

string_response problem_response(problem p, unsigned version, bool keep_alive, std::string_view target,
                                 const std::string& request_id) {
    if (p.instance.empty()) p.instance = std::string(target_path(target));
    p.request_id = request_id;
    string_response res{static_cast<http::status>(p.status), version};
    set_common_headers(res, request_id, keep_alive);
    res.set(http::field::content_type, problem_content_type);
    if (p.status == 401) res.set(http::field::www_authenticate, "Bearer realm=\"asi-gateway\"");
    if (p.retry_after_s > 0) res.set(http::field::retry_after, std::to_string(p.retry_after_s));
    res.body() = to_json_text(p.to_json());
    res.prepare_payload();
    return res;
}

string_response problem_response(problem p, const string_request& req, const std::string& request_id) {
    return problem_response(std::move(p), req.version(), req.keep_alive(), req.target(), request_id);
}

}  // namespace gw::api
