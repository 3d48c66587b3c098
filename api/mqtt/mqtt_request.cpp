#include "api/mqtt/mqtt_request.hpp"

#include <utility>

#include "gateway/common/operation_error.hpp"

namespace gw::api {

using nlohmann::json;

namespace {

mqtt_request_error invalid(json id, std::optional<std::string> reply_to, std::string_view topic,
                           std::string field, std::string detail) {
    auto p =
        make_problem(make_error(operation_error_kind::invalid_value, std::move(detail), std::move(field)));
    p.instance = std::string(topic);
    return {std::move(id), std::move(reply_to), std::move(p)};
}

}  // namespace

boost::system::result<mqtt_envelope, std::string> open_mqtt_envelope(std::string_view payload,
                                                                     std::size_t max_payload_bytes) {
    using result = boost::system::result<mqtt_envelope, std::string>;
    auto refuse = [](std::string why) { return result(boost::system::in_place_error, std::move(why)); };
    if (payload.size() > max_payload_bytes)
        return refuse("a payload of " + std::to_string(payload.size()) +
                      " bytes, over mqtt.commands.max_payload_bytes (" + std::to_string(max_payload_bytes) +
                      ")");
    json msg = json::parse(payload, nullptr, /*allow_exceptions=*/false);
    if (msg.is_discarded()) return refuse("the payload is not valid JSON");
    if (!msg.is_object()) return refuse("the payload is not a JSON object");
    mqtt_envelope e;
    if (auto it = msg.find("token"); it != msg.end()) {
        if (!it->is_string() || it->get_ref<const std::string&>().size() > mqtt_max_token_bytes)
            return refuse("\"token\" is not a string of at most " + std::to_string(mqtt_max_token_bytes) +
                          " bytes");
        e.token = it->get<std::string>();
        msg.erase(it);
    }
    e.message = std::move(msg);
    return e;
}

boost::system::result<mqtt_request, mqtt_request_error> parse_mqtt_request(const mqtt_topics& topics,
                                                                           const mqtt_command_target& target,
                                                                           std::string_view topic,
                                                                           mqtt_envelope envelope,
                                                                           std::string_view generated_id) {
    json& msg = envelope.message;
    // reply_to first, so that later errors can be answered where the client listens.
    std::optional<std::string> reply_to;
    // An id that is not a string or an integer is refused by the WebSocket parser; never echo it.
    const json given = msg.contains("id") ? msg["id"] : json();
    const json id = given.is_string() || given.is_number_integer() ? given
                    : msg.contains("id")                           ? json()
                                                                   : json(std::string(generated_id));
    if (auto it = msg.find("reply_to"); it != msg.end()) {
        if (!it->is_string() || !topics.is_allowed_reply_topic(it->get_ref<const std::string&>()))
            return invalid(
                id, std::nullopt, topic, "reply_to",
                "\"reply_to\" must be a topic name without wildcards, outside \"" + topics.prefix() + "/\"");
        reply_to = it->get<std::string>();
        msg.erase(it);
    }
    std::optional<std::int64_t> not_after;
    if (auto it = msg.find("not_after"); it != msg.end()) {
        // Integers only: a float or a string would be a guess at the unit.
        if (!it->is_number_integer() || it->get<std::int64_t>() < 0)
            return invalid(id, reply_to, topic, "not_after",
                           "\"not_after\" must be Unix milliseconds (an integer): the time after which the "
                           "command must not run");
        not_after = it->get<std::int64_t>();
        msg.erase(it);
    }
    // What the topic says may not be said again in the payload.
    const bool for_controller = target.kind == mqtt_command_kind::controller;
    for (const char* from_topic : {"op", "controller", "action"}) {
        if (std::string_view(from_topic) == "controller" && !for_controller) continue;
        if (msg.contains(from_topic))
            return invalid(id, reply_to, topic, from_topic,
                           std::string("\"") + from_topic + "\" comes from the topic; leave it out");
    }
    if (!msg.contains("id")) msg["id"] = id;
    if (for_controller) {
        msg["op"] = "command";
        msg["controller"] = target.controller;
    } else if (target.kind == mqtt_command_kind::halt_all) {
        msg["op"] = "halt_all";
    } else {
        msg["op"] = target.kind == mqtt_command_kind::gcode_check ? "gcode" : "job";
        msg["action"] = std::string(to_string(target.kind));
    }
    auto parsed = parse_client_json(msg);
    if (!parsed) {
        auto e = std::move(parsed.error());
        e.error.instance = std::string(topic);
        return mqtt_request_error{e.id.is_null() ? id : e.id, reply_to, std::move(e.error)};
    }
    return mqtt_request{target,
                        std::move(envelope.token),
                        std::move(reply_to),
                        std::move(*parsed),
                        id,
                        given.is_string() || given.is_number_integer(),
                        not_after};
}

std::string mqtt_request_id(const json& id) {
    return ws_request_id("mqtt", id);
}

}  // namespace gw::api
