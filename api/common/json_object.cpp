#include "api/common/json_object.hpp"

#include <algorithm>

#include "api/common/printable_text.hpp"

namespace gw::api {

std::optional<unknown_field> find_unknown_field(const nlohmann::json& object,
                                                std::initializer_list<std::string_view> known,
                                                std::string_view none_known) {
    if (!object.is_object()) return std::nullopt;
    for (const auto& [key, value] : object.items()) {
        if (std::find(known.begin(), known.end(), key) != known.end()) continue;
        std::string list;
        for (auto k : known)
            list += (list.empty() ? "" : ", ") + std::string(k);
        auto shown = shown_in_message(key);
        auto message = "unknown field \"" + shown + "\" (" +
                       (list.empty() ? std::string(none_known) : "known: " + list) + ")";
        return unknown_field{std::move(shown), std::move(message)};
    }
    return std::nullopt;
}

std::string_view json_type_name(const nlohmann::json& v) {
    if (v.is_number()) return "a number";
    return v.type_name();
}

}  // namespace gw::api
