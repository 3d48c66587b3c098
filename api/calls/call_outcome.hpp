#pragma once
// The one outcome of every call (operations, HALT ALL, jobs, leases, G-code checks), before a
// transport turns it into an HTTP response, a WebSocket message or an MQTT answer.

#include <optional>
#include <string>

#include <boost/asio/any_completion_handler.hpp>
#include <nlohmann/json.hpp>

#include "api/common/problem.hpp"
#include "gateway/common/operation_error.hpp"

namespace gw::api {

struct api_outcome {
    std::optional<problem> error;  // set on failure (request_id filled in; instance left empty)
    unsigned status = 200;         // on success: 200, 201 or 204 (no body)
    nlohmann::json body;           // on success (null for 204)
    std::string location;          // 201: the new resource's path
    bool replayed = false;         // an Idempotency-Key seen before: the first submission's job
};

using api_handler = boost::asio::any_completion_handler<void(api_outcome)>;

api_outcome failed(problem p, const std::string& request_id);
api_outcome failed(const operation_error& e, const std::string& request_id);

}  // namespace gw::api
