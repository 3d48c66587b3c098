#pragma once
// One HTTP request on its way through a route handler (route_table.hpp): the request, what the table
// found (route template, path parameters, the caller once authorised), and the helpers every handler
// uses to read the query, the body and the key headers and to answer. Each helper that refuses
// answers the request itself (a problem+json) and returns nothing; the handler then just returns.
// `done` is called exactly once, by reply() or by the handler given to async_reply().

#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "api/calls/job_requests.hpp"
#include "api/common/api_context.hpp"
#include "api/common/auth.hpp"
#include "api/common/caller.hpp"
#include "api/common/net.hpp"
#include "api/common/response_headers.hpp"
#include "api/http/router.hpp"

namespace gw::api {

struct request_context {
    std::shared_ptr<api_context> ctx;
    string_request req;
    std::string request_id;
    net::any_io_executor session_executor;
    response_handler done;
    std::string route{};                 // the template, for metrics: "/api/v1/controllers/{id}/move"
    std::vector<std::string> params{};   // the path's {placeholders}, in order
    std::optional<auth_identity> who{};  // the caller, when the route needs a role
    std::string client_address{};        // the peer's address ("127.0.0.1")

    // The caller of a call this request makes (api/calls.hpp), over REST.
    caller as_caller() const {
        return caller{who ? who->name : "anonymous",
                      who ? who->role : gw::role::viewer,
                      request_id,
                      std::nullopt,
                      "rest",
                      client_address};
    }

    response_meta meta() const { return meta_of(req, request_id); }

    void reply(string_response res);
    void fail(problem p);
    void fail(const operation_error& e);
    void reply_json(http::status status, const nlohmann::json& body);
    void reply_body(http::status status, std::string body, std::string_view content_type);
    void reply_outcome(api_outcome o);
    // A 200 whose body `body` makes piece by piece (chunked); `headers` are added to the common ones.
    void reply_stream(std::string_view content_type, std::shared_ptr<streamed_body> body,
                      std::vector<std::pair<http::field, std::string>> headers = {});
    // The answer of an asynchronous route, delivered on the session's executor. Moves `done` out: call
    // it once, and answer nothing else after.
    api_handler async_reply();

    // The query string, or a 400 answered.
    std::optional<query_params> query();
    // The query with only `known` parameters, or a 422 answered.
    std::optional<query_params> query_with(std::initializer_list<std::string_view> known);
    // The body as JSON (null when empty), or a 400 answered.
    std::optional<nlohmann::json> json_body();
    // A Lease-Id / Idempotency-Key header into `value` (absent: nullopt); false with a 422 answered.
    bool key_header(std::string_view name, std::optional<std::string>& value);
};

}  // namespace gw::api
