#include "gateway/jobs/kinds/spec_fields.hpp"

#include <fmt/format.h>

#include "gateway/common/json_keys.hpp"
#include "gateway/common/json_value.hpp"

namespace gw::jobs {

operation_error spec_error(const std::string& field, std::string message) {
    return make_error(operation_error_kind::invalid_value, std::move(message), "spec." + field);
}

operation_result<void> spec_known_fields(const nlohmann::json& object, const std::string& prefix,
                                         std::initializer_list<std::string_view> known) {
    if (const auto key = first_unknown_key(object, known))
        return spec_error(prefix + *key, fmt::format("unknown field {}{}", prefix, *key));
    return {};
}

operation_result<double> spec_number(const nlohmann::json& v, const std::string& field, double lo,
                                     double hi) {
    auto d = read_number(v, lo, hi);
    if (d) return *d.value;
    if (d.fault == json_fault::wrong_type)
        return spec_error(field, fmt::format("{} must be a number", field));
    return spec_error(field, fmt::format("{} must be between {} and {}", field, lo, hi));
}

operation_result<int> spec_integer(const nlohmann::json& v, const std::string& field, int lo, int hi) {
    auto i = read_integer(v, lo, hi);
    if (i) return static_cast<int>(*i.value);
    if (i.fault == json_fault::wrong_type)
        return spec_error(field, fmt::format("{} must be an integer", field));
    return spec_error(field, fmt::format("{} must be between {} and {}", field, lo, hi));
}

operation_result<std::string> spec_text(const nlohmann::json& v, const std::string& field) {
    auto t = read_text(v);
    if (!t) return spec_error(field, fmt::format("{} must be a string", field));
    return std::move(*t.value);
}

}  // namespace gw::jobs
