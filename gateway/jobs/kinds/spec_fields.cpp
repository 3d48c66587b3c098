#include "gateway/jobs/kinds/spec_fields.hpp"

#include <cmath>
#include <fmt/format.h>

namespace gw::jobs {

operation_error spec_error(const std::string& field, std::string message) {
    return make_error(operation_error_kind::invalid_value, std::move(message), "spec." + field);
}

operation_result<double> spec_number(const nlohmann::json& v, const std::string& field, double lo,
                                     double hi) {
    if (!v.is_number()) return spec_error(field, fmt::format("{} must be a number", field));
    const double d = v.get<double>();
    if (!std::isfinite(d) || d < lo || d > hi)
        return spec_error(field, fmt::format("{} must be between {} and {}", field, lo, hi));
    return d;
}

operation_result<int> spec_integer(const nlohmann::json& v, const std::string& field, long long lo,
                                   long long hi) {
    // As JSON Schema counts integers: 20.0 is one (some clients write every number as a float).
    const bool whole_float = v.is_number_float() && std::isfinite(v.get<double>()) &&
                             std::trunc(v.get<double>()) == v.get<double>() &&
                             std::fabs(v.get<double>()) < 9e15;
    if (!v.is_number_integer() && !whole_float)
        return spec_error(field, fmt::format("{} must be an integer", field));
    const auto i = whole_float ? static_cast<long long>(v.get<double>()) : v.get<long long>();
    if (i < lo || i > hi)
        return spec_error(field, fmt::format("{} must be between {} and {}", field, lo, hi));
    return static_cast<int>(i);
}

operation_result<std::string> spec_text(const nlohmann::json& v, const std::string& field) {
    if (!v.is_string()) return spec_error(field, fmt::format("{} must be a string", field));
    return v.get<std::string>();
}

}  // namespace gw::jobs
