#include "api/common/problem.hpp"

#include <algorithm>

namespace gw::api {

namespace {

struct kind_info {
    unsigned status;
    std::string_view title;
};

kind_info info(operation_error_kind k) {
    using enum operation_error_kind;
    switch (k) {
        case unknown_controller:
            return {404, "Unknown controller"};
        case invalid_value:
            return {422, "Invalid value"};
        case missing_module:
            return {409, "Missing firmware module"};
        case busy:
            return {409, "Controller busy"};
        case leased:
            return {409, "Controller leased"};
        case not_connected:
            return {503, "Controller not connected"};
        case timeout:
            return {504, "Controller timeout"};
        case controller_error:
            return {502, "Controller error"};
        case queue_full:
            return {503, "Controller queue full"};
        case unknown_job:
            return {404, "Unknown job"};
        case invalid_state:
            return {409, "Invalid state"};
        case storage_unavailable:
            return {503, "Storage unavailable"};
        case unknown_file:
            return {404, "Unknown G-code file"};
        case halted:
            return {409, "Halted"};
        case job_active:
            return {409, "Job active"};
        case unknown_recording:
            return {404, "Unknown recording"};
        case stale_command:
            return {408, "Stale command"};
        case internal:
            break;
    }
    return {500, "Internal error"};
}

kind_info info(http_error e) {
    using enum http_error;
    switch (e) {
        case malformed_json:
            return {400, "Malformed JSON"};
        case bad_request:
            return {400, "Bad request"};
        case unauthorized:
            return {401, "Unauthorized"};
        case forbidden:
            return {403, "Forbidden"};
        case not_found:
            return {404, "Not found"};
        case method_not_allowed:
            return {405, "Method not allowed"};
        case payload_too_large:
            return {413, "Payload too large"};
        case header_too_large:
            return {431, "Request header fields too large"};
        case not_implemented:
            return {501, "Not implemented"};
        case too_many_connections:
            return {503, "Too many connections"};
        case body_budget_exhausted:
            return {503, "Request body budget exhausted"};
        case cross_origin:
            return {403, "Cross-origin request"};
        case unsupported_media_type:
            return {415, "Unsupported media type"};
        case misdirected_request:
            return {421, "Misdirected request"};
    }
    return {500, "Internal error"};
}

}  // namespace

std::string_view to_string(http_error e) {
    using enum http_error;
    switch (e) {
        case malformed_json:
            return "malformed_json";
        case bad_request:
            return "bad_request";
        case unauthorized:
            return "unauthorized";
        case forbidden:
            return "forbidden";
        case not_found:
            return "not_found";
        case method_not_allowed:
            return "method_not_allowed";
        case payload_too_large:
            return "payload_too_large";
        case header_too_large:
            return "header_too_large";
        case not_implemented:
            return "not_implemented";
        case too_many_connections:
            return "too_many_connections";
        case body_budget_exhausted:
            return "body_budget_exhausted";
        case cross_origin:
            return "cross_origin";
        case unsupported_media_type:
            return "unsupported_media_type";
        case misdirected_request:
            return "misdirected_request";
    }
    return "internal";
}

std::string problem::type() const {
    std::string t(problem_type_base);
    std::string k = kind;
    std::replace(k.begin(), k.end(), '_', '-');
    return t + k;
}

nlohmann::json problem::to_json() const {
    nlohmann::json j = {{"type", type()}, {"title", title}, {"status", status}, {"detail", detail}};
    if (!instance.empty()) j["instance"] = instance;
    if (!request_id.empty()) j["request_id"] = request_id;
    if (!field.empty()) j["field"] = field;
    if (controller_code != 0) {
        j["controller_code"] = controller_code;
        j["controller_code_name"] = controller_code_name;
    }
    if (program) {
        j["line"] = program->line;
        j["column"] = program->column;
        j["message"] = program->message;
    }
    return j;
}

problem make_problem(const operation_error& e) {
    auto i = info(e.kind);
    problem p;
    p.status = i.status;
    p.kind = std::string(to_string(e.kind));
    p.title = std::string(i.title);
    p.detail = e.message;
    p.field = e.field;
    p.controller_code = e.controller_code;
    p.controller_code_name = e.controller_code_name;
    return p;
}

problem make_problem(http_error e, std::string detail) {
    auto i = info(e);
    problem p;
    p.status = i.status;
    p.kind = std::string(to_string(e));
    p.title = std::string(i.title);
    p.detail = std::move(detail);
    if (p.status == 503) p.retry_after_s = 1;  // connections and body memory free up within moments
    return p;
}

}  // namespace gw::api
