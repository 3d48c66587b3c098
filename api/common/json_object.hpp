#pragma once
// The one strict reading of a JSON object that a client sent (a REST body, a WebSocket message, an
// MQTT payload): every key must be one the receiver knows, and an error names what a value is.

#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace gw::api {

// A key the receiver does not know: `field` for problem+json, `message` for people
// ("unknown field \"spd\" (known: speed, accel)"; "(this operation takes none)" when `known` is
// empty). The key appears as shown_in_message() shows it.
struct unknown_field {
    std::string field;
    std::string message;
};

// The first key of `object` not in `known`; nullopt when every key is known or `object` is not an
// object (the caller says what it expected instead).
std::optional<unknown_field> find_unknown_field(const nlohmann::json& object,
                                                std::initializer_list<std::string_view> known,
                                                std::string_view none_known = "this message takes none");

// What a value is, for "must be a string, not a number" (every number is "a number").
std::string_view json_type_name(const nlohmann::json& v);

}  // namespace gw::api
