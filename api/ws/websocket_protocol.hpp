#pragma once
// The JSON messages of /api/v1/ws: parsing and validating what a client sends, building what the
// server answers. Events themselves are not built here: the hub serialises each one once
// (gateway/events/event.hpp) and every session sends that text as is. Pure: no I/O, no clock, no logging.
//
// Client -> server (one JSON object per text frame; "id" is optional except for commands: a string
// of 1..128 printable characters or an integer, echoed in the answer):
//   {"op":"subscribe","id":1,"topics":["controllers/+/position","jobs/#"],
//    "resume":{"controllers/sim1/reports":41},"max_rate_hz":10}
//   {"op":"unsubscribe","id":2,"topics":["jobs/#"]}
//   {"op":"command","id":"c7","controller":"sim1","operation":"move",
//    "args":{"axes":{"X":1000},"mode":"absolute"}}
//   {"op":"job","id":"s1","action":"submit","args":{"controller":"sim1","type":"array","spec":{...}},
//    "lease":"l-...","idempotency_key":"plate-7","dry_run":false}
//   {"op":"job","id":"s2","action":"cancel"|"pause"|"resume"|"next"|"get","job":"j-...","lease":"l-..."}
//   {"op":"gcode","id":"g1","action":"check","file":"g-...","options":{"xyz_scale":0.5}}
//   {"op":"halt_all","id":"h1"}   HALT ALL (api/halt_requests.hpp); role auth.halt_role
//   {"op":"ping","id":3}
// "lease" (also on "command"): the lease id, like the REST header Lease-Id; while a controller is
// leased, commands (but halt), job submissions and job actions without its lease get 409 leased.
// Job args are the REST body of POST /api/v1/jobs; roles as REST (get: viewer, others: operator).
// A G-code check plans a stored program (viewer): the result is the plan's summary, as POST
// /api/v1/gcode/files/{id}/plan?moves=false answers; "options" are that route's query parameters.
// Server -> client:
//   {"type":"hello","connection":"ws-5","user":"anonymous","role":"admin","client":null,"auth":"none",
//    "max_message_bytes":65536}      (role, client, auth: as GET /api/v1/whoami answers)
//   {"type":"subscribed","id":1,"topics":[...],"resume":{...},"max_rate_hz":10}
//   {"type":"unsubscribed","id":2,"topics":[...]}
//   {"type":"result","id":"c7","result":{...the REST result body...}}
//   {"type":"result","id":"s1","result":{...the first job...},"replayed":true}   (Idempotency replay)
//   {"type":"error","id":"c7"|null,"problem":{...the application/problem+json body...}}
//   {"type":"pong","id":3}
//   {"type":"event",...}, {"type":"gap",...} and {"type":"retired",...} exactly as in
//   gateway/events/event.hpp. "retired": the topic left the hub (an ended job's topic,
//   events.ended_job_topic_ttl_s after the job's last event): nothing more comes on it; sent to its
//   subscribers then, and at once to a subscription that names it or resumes it later. A job's history: GET
//   /api/v1/jobs/{id}/events.
//   {"type":"batch","events":[{"type":"event",...},{"type":"gap",...},...]}   (batched connections)
// A message that cannot be used (malformed JSON, unknown op or field, wrong type, bad topic filter)
// is answered with an error message; the connection stays open.
//
// Batching: a client that connects to /api/v1/ws?batch_ms=N (0..1000) gets its events in "batch"
// messages: the event, gap and retired messages above, unchanged and in order, at most one batch per
// tick of N ms (ticks shared by the sessions with the same N, which then send the same bytes:
// batch_text_cache; 0: as fast as the client takes them, each batch holding what queued meanwhile). Answers
// (result, error, subscribed, ...) stay single messages. One write per batch instead of one per event
// is what lets a client follow hundreds of report streams; under load the batches grow instead of
// the connection being dropped. The hello says which mode is on ("batch_ms": N or null).

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <boost/system/result.hpp>
#include <nlohmann/json.hpp>

#include "api/calls/calls.hpp"
#include "api/common/problem.hpp"
#include "gateway/common/operation_error.hpp"
#include "gateway/events/event.hpp"

namespace gw::api {

inline constexpr std::string_view websocket_path = "/api/v1/ws";
inline constexpr std::size_t ws_max_topics_per_message = 64;
inline constexpr std::size_t ws_max_client_id_bytes = 128;
inline constexpr double ws_max_rate_hz = 1000;

struct ws_subscribe {
    nlohmann::json id;  // null when absent
    std::vector<std::string> topics;
    std::map<std::string, std::uint64_t> resume;  // topic name -> last sequence number the client has
    double max_rate_hz = 0;                       // 0: no limit (latest-value topics still coalesce)
};

struct ws_unsubscribe {
    nlohmann::json id;
    std::vector<std::string> topics;
};

// The two messages WebSocket and MQTT share (MQTT parses its payloads with parse_client_json): an
// operation on a controller, and a job submission or action. Both become calls (api/calls.hpp).
struct command_message {
    nlohmann::json id;  // never null
    std::string controller;
    std::string operation;             // one of operation_names()
    nlohmann::json args;               // an object ({} when absent)
    std::optional<std::string> lease;  // "lease": the lease id, when the client holds one
};

// A job submission or a job action.
struct job_message {
    nlohmann::json id;    // never null
    std::string action;   // "submit", "get", "cancel", "pause", "resume", "next"
    std::string job;      // the job id: every action but submit
    nlohmann::json args;  // submit: {"controller","type","spec"} (validated when submitted)
    std::optional<std::string> lease;
    std::optional<std::string> idempotency_key;  // submit only
    bool dry_run = false;                        // submit only
};

struct gcode_message {
    nlohmann::json id;       // never null
    std::string action;      // "check"
    std::string file;        // "g-..."
    nlohmann::json options;  // an object, or null (validated when dispatched)
};

// HALT ALL.
struct halt_all_message {
    nlohmann::json id;  // never null
};

struct ws_ping {
    nlohmann::json id;
};

using ws_client_message = std::variant<ws_subscribe, ws_unsubscribe, command_message, job_message,
                                       gcode_message, halt_all_message, ws_ping>;

// Why a client message was refused; `id` is the message's id when it had a valid one, else null.
struct ws_protocol_error {
    nlohmann::json id;
    problem error;  // 400 malformed_json, or 422 invalid_value with `field`
};

boost::system::result<ws_client_message, ws_protocol_error> parse_client_message(std::string_view text);
// The same for a message already parsed (the MQTT command topics build theirs from a payload and the
// topic); `msg` that is not an object is malformed_json.
boost::system::result<ws_client_message, ws_protocol_error> parse_client_json(const nlohmann::json& msg);

// A binary frame (the protocol is text only).
ws_protocol_error binary_frame_error();

// The request id of a command: "<connection>.<client id>" ("ws-5.c7", "ws-5.42"), so that logs and
// serial traces of a WebSocket command lead back to the connection and the client's message.
std::string ws_request_id(std::string_view connection, const nlohmann::json& client_id);

// `whoami`: whoami_json() of the client (api/auth.hpp); its role, client and auth go into the hello.
std::string ws_hello_message(std::string_view connection, std::string_view user, const nlohmann::json& whoami,
                             std::size_t max_message_bytes,
                             std::optional<std::chrono::milliseconds> batch_window = std::nullopt);

// What a client chose in the upgrade's query (other parameters, access_token among them, are not
// judged here). batch_ms not an integer 0..1000: invalid_value naming it.
struct websocket_options {
    std::optional<std::chrono::milliseconds> batch_window;  // batch_ms; none: one message per event
};
inline constexpr std::chrono::milliseconds max_batch_window{1000};
operation_result<websocket_options> parse_websocket_options(std::string_view target);

// {"type":"batch","events":[...]}: the events' own messages (each serialised once by the hub), joined.
std::string ws_batch_message(const std::vector<std::shared_ptr<const event>>& events);
std::string ws_subscribed_message(const ws_subscribe& request);
std::string ws_unsubscribed_message(const ws_unsubscribe& request);
// The call a command or job message asks for (api/calls.hpp); the lease is the caller's.
call to_call(command_message m);
call to_call(job_message m);
call to_call(gcode_message m);

// The answer to a call, the same on WebSocket and MQTT: {"type":"result","id":..,"result":..} (with
// "replayed": true for an Idempotency-Key seen before) or {"type":"error","id":..,"problem":<problem>}.
std::string call_result_message(const nlohmann::json& id, const nlohmann::json& result,
                                bool replayed = false);
std::string call_error_message(const nlohmann::json& id, const problem& error);
std::string ws_pong_message(const nlohmann::json& id);

}  // namespace gw::api
