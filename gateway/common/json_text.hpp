#pragma once
// JSON to text for anything that leaves the process (HTTP bodies, events, MQTT payloads, the store).
// Strings may hold bytes a controller or a client sent: invalid UTF-8 is replaced by U+FFFD instead
// of throwing, so no input can make an encoder end the process.

#include <string>

#include <nlohmann/json.hpp>

namespace gw {

inline std::string to_json_text(const nlohmann::json& j) {
    return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace gw
