#pragma once
// A command received on an MQTT command topic, parsed. Pure.
//
// The payload is the WebSocket message without "op" (and without "controller" / "action", which the
// topic gives), plus the MQTT envelope fields "token" and "reply_to":
//   <base>/controllers/sim1/cmd   {"id":"c7","operation":"move","args":{"axes":{"X":1000}},
//                                  "lease":"l-...","token":"<bearer token>","reply_to":"me/replies",
//                                  "not_after":1796545200000}
//   <base>/jobs/submit            {"id":"s1","args":{"controller":"sim1","type":"array","spec":{...}},
//                                  "idempotency_key":"plate-7","dry_run":false,"token":"..."}
//   <base>/jobs/cancel|pause|resume|next   {"id":"x","job":"j-...","lease":"l-...","token":"..."}
// The message then goes through the WebSocket parser (api/websocket_protocol.hpp), so field checks,
// operation names, lease and idempotency keys are exactly those of REST and WebSocket. "id" is
// optional here (MQTT 5 clients correlate by correlation data); without it the gateway names the
// request "mqtt-<n>" and echoes that.
// "not_after" (Unix milliseconds) is the time after which the command must not run
// (api/mqtt/command_deadline.hpp).
// Answers go to the MQTT 5 response topic, else to "reply_to" (3.1.1 clients); the response is the
// WebSocket "result" or "error" message.
//
// A signed payload (api/mqtt/mqtt_signature.hpp) is verified first; its body is the payload here.
// Two steps, so that nothing of a message is believed before its sender is known:
//   1. open_mqtt_envelope: within the size cap, a JSON object, its "token" taken out. A failure here
//      is never answered (anyone may publish on a command topic the broker lets them write to, and
//      an answer would make the gateway publish for them); the caller counts and logs it.
//   2. the caller authenticates the token (a failure is not answered either), then
//      parse_mqtt_request reads the rest; its errors are answered.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include <boost/system/result.hpp>
#include <nlohmann/json.hpp>

#include "api/common/problem.hpp"
#include "api/mqtt/mqtt_topics.hpp"
#include "api/ws/websocket_protocol.hpp"

namespace gw::api {

inline constexpr std::size_t mqtt_max_token_bytes = 1024;

struct mqtt_request {
    mqtt_command_target target;
    std::string token;                    // "" when absent (refused later as 401)
    std::optional<std::string> reply_to;  // the payload's reply_to, already checked
    ws_client_message message;            // command_message or job_message
    nlohmann::json id;                    // the message id (given or generated)
    bool id_given = false;                // the payload named it (so a redelivery can be known)
    std::optional<std::int64_t> not_after_ms;
};

struct mqtt_request_error {
    nlohmann::json id;                    // null when unknown
    std::optional<std::string> reply_to;  // when the payload named a usable one
    problem error;                        // instance: the topic
};

struct mqtt_envelope {
    nlohmann::json message;  // a JSON object, without "token"
    std::string token;       // "" when absent
};

// Step 1: why the payload is not even looked at (for the log), or its envelope.
boost::system::result<mqtt_envelope, std::string> open_mqtt_envelope(std::string_view payload,
                                                                     std::size_t max_payload_bytes);

// Step 2, for an authenticated sender: `topics` checks reply_to; `generated_id` is used when the
// payload has no "id".
boost::system::result<mqtt_request, mqtt_request_error> parse_mqtt_request(const mqtt_topics& topics,
                                                                           const mqtt_command_target& target,
                                                                           std::string_view topic,
                                                                           mqtt_envelope envelope,
                                                                           std::string_view generated_id);

// The request id written next to serial commands: "mqtt.<the request's id>" (the message's "id", or
// the generated "mqtt-<n>").
std::string mqtt_request_id(const nlohmann::json& id);

}  // namespace gw::api
