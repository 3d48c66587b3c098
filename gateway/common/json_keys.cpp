#include "gateway/common/json_keys.hpp"

#include <algorithm>

namespace gw {

std::optional<std::string> first_unknown_key(const nlohmann::json& object,
                                             std::initializer_list<std::string_view> known) {
    if (!object.is_object()) return std::nullopt;
    for (const auto& [key, value] : object.items())
        if (std::find(known.begin(), known.end(), key) == known.end()) return key;
    return std::nullopt;
}

}  // namespace gw
