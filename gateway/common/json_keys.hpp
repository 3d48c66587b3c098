#pragma once
// The one check of a JSON object's keys against those its reader knows: the config file, the job specs
// and what clients send (api/common/json_object) all refuse a key they do not know, each in its own
// words. Pure.

#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace gw {

// The first key of `object` (in its order) that is not in `known`; nullopt when every key is known or
// `object` is no object (its reader says what it expected instead).
std::optional<std::string> first_unknown_key(const nlohmann::json& object,
                                             std::initializer_list<std::string_view> known);

}  // namespace gw
