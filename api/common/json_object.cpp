#include "api/common/json_object.hpp"

#include "api/common/printable_text.hpp"
#include "gateway/common/json_keys.hpp"

namespace gw::api {

std::optional<unknown_field> find_unknown_field(const nlohmann::json& object,
                                                std::initializer_list<std::string_view> known,
                                                std::string_view none_known) {
    const auto key = first_unknown_key(object, known);
    if (!key) return std::nullopt;
    std::string list;
    for (auto k : known)
        list += (list.empty() ? "" : ", ") + std::string(k);
    auto shown = shown_in_message(*key);
    auto message = "unknown field \"" + shown + "\" (" +
                   (list.empty() ? std::string(none_known) : "known: " + list) + ")";
    return unknown_field{std::move(shown), std::move(message)};
}

std::string_view json_type_name(const nlohmann::json& v) {
    if (v.is_number()) return "a number";
    return v.type_name();
}

}  // namespace gw::api
