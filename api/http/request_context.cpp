#include "api/http/request_context.hpp"

#include <boost/asio/bind_executor.hpp>

#include "api/http/browser_guard.hpp"
#include "gateway/common/json_text.hpp"

namespace gw::api {

void request_context::reply(string_response res) {
    done(routed_response{std::move(res), route});
}

void request_context::fail(problem p) {
    reply(problem_response(std::move(p), req, request_id));
}

void request_context::fail(const operation_error& e) {
    fail(make_problem(e));
}

void request_context::reply_json(http::status status, const nlohmann::json& body) {
    reply_body(status, to_json_text(body), "application/json");
}

void request_context::reply_body(http::status status, std::string body, std::string_view content_type) {
    reply(body_response(status, std::move(body), content_type, meta()));
}

void request_context::reply_outcome(api_outcome o) {
    reply(outcome_response(std::move(o), req.version(), req.keep_alive(), req.target(), request_id));
}

void request_context::reply_stream(std::string_view content_type, std::shared_ptr<streamed_body> body,
                                   std::vector<std::pair<http::field, std::string>> headers) {
    string_response head{http::status::ok, req.version()};
    set_common_headers(head, request_id, req.keep_alive());
    head.set(http::field::content_type, content_type);
    for (auto& [name, value] : headers)
        head.set(name, std::move(value));
    done(routed_response{std::move(head), route, std::move(body)});
}

api_handler request_context::async_reply() {
    return net::bind_executor(
        session_executor, [route = route, meta = meta(), done = std::move(done)](api_outcome o) {
            done({outcome_response(std::move(o), meta.version, meta.keep_alive, meta.target, meta.request_id),
                  route});
        });
}

std::optional<query_params> request_context::query() {
    auto q = parse_query(req.target());
    if (!q) {
        fail(q.error());
        return std::nullopt;
    }
    return std::move(*q);
}

std::optional<query_params> request_context::query_with(std::initializer_list<std::string_view> known) {
    auto q = query();
    if (!q) return std::nullopt;
    if (auto ok = check_known_parameters(*q, known); !ok) {
        fail(ok.error());
        return std::nullopt;
    }
    return q;
}

std::optional<nlohmann::json> request_context::json_body() {
    nlohmann::json body;
    if (req.body().empty()) return body;
    // A page of another site can post a form or text/plain without asking first; JSON it cannot.
    if (!is_json_content_type(req[http::field::content_type])) {
        fail(unsupported_media_type_problem());
        return std::nullopt;
    }
    body = nlohmann::json::parse(req.body(), nullptr, false);
    if (body.is_discarded()) {
        fail(make_problem(http_error::malformed_json, "the request body is not valid JSON"));
        return std::nullopt;
    }
    return body;
}

bool request_context::key_header(std::string_view name, std::optional<std::string>& value) {
    value.reset();
    auto it = req.find(name);
    if (it == req.end()) return true;
    value = std::string(it->value());
    if (is_valid_key(*value)) return true;
    fail(make_error(operation_error_kind::invalid_value,
                    std::string(name) + " must be 1..128 printable ASCII characters", std::string(name)));
    return false;
}

}  // namespace gw::api
