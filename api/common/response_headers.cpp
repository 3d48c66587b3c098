#include "api/common/response_headers.hpp"

namespace gw::api {

response_meta meta_of(const string_request& request, std::string request_id) {
    return {request.version(), request.keep_alive(), std::string(request.target()), std::move(request_id)};
}

void set_common_headers(string_response& res, const std::string& request_id, bool keep_alive,
                        std::string_view cache_control) {
    res.set(http::field::server, "asi-gateway");
    res.set("X-Request-Id", request_id);
    res.set(http::field::cache_control, cache_control);
    res.keep_alive(keep_alive);
}

string_response body_response(http::status status, std::string body, std::string_view content_type,
                              const response_meta& meta) {
    string_response res{status, meta.version};
    set_common_headers(res, meta.request_id, meta.keep_alive);
    if (status != http::status::no_content) {
        res.set(http::field::content_type, content_type);
        res.body() = std::move(body);
    }
    res.prepare_payload();
    return res;
}

}  // namespace gw::api
