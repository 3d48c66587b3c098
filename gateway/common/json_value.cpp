#include "gateway/common/json_value.hpp"

#include <algorithm>
#include <cmath>

namespace gw {

namespace {

template <typename T>
json_read<T> refused(json_fault why) {
    return json_read<T>{std::nullopt, why};
}

}  // namespace

json_read<double> read_number(const nlohmann::json& v, double lo, double hi) {
    if (!v.is_number()) return refused<double>(json_fault::wrong_type);
    const double d = v.get<double>();
    if (!std::isfinite(d) || d < lo || d > hi) return refused<double>(json_fault::out_of_range);
    return {d};
}

json_read<long long> read_integer(const nlohmann::json& v, long long lo, long long hi) {
    // Beyond 2^53 a float no longer tells integers apart.
    constexpr double largest_exact_float = 9e15;
    const bool whole_float = v.is_number_float() && std::isfinite(v.get<double>()) &&
                             std::trunc(v.get<double>()) == v.get<double>() &&
                             std::fabs(v.get<double>()) < largest_exact_float;
    if (!v.is_number_integer() && !whole_float) return refused<long long>(json_fault::wrong_type);
    if (v.is_number_unsigned() && v.get<std::uint64_t>() > static_cast<std::uint64_t>(hi))
        return refused<long long>(json_fault::out_of_range);
    const auto i = whole_float ? static_cast<long long>(v.get<double>()) : v.get<long long>();
    if (i < lo || i > hi) return refused<long long>(json_fault::out_of_range);
    return {i};
}

json_read<std::uint64_t> read_unsigned(const nlohmann::json& v, std::uint64_t lo, std::uint64_t hi) {
    // A parsed "20" is unsigned; a json(20) built in code is a signed integer.
    const bool whole = v.is_number_unsigned() || (v.is_number_integer() && v.get<long long>() >= 0);
    if (!whole) return refused<std::uint64_t>(json_fault::wrong_type);
    const auto u = v.get<std::uint64_t>();
    if (u < lo || u > hi) return refused<std::uint64_t>(json_fault::out_of_range);
    return {u};
}

json_read<std::string> read_text(const nlohmann::json& v, text_rules rules) {
    if (!v.is_string()) return refused<std::string>(json_fault::wrong_type);
    auto s = v.get<std::string>();
    if (s.empty() && !rules.allow_empty) return refused<std::string>(json_fault::empty);
    const auto control = [](unsigned char c) { return c < 0x20 || c == 0x7f; };
    if (!rules.allow_control && std::any_of(s.begin(), s.end(), control))
        return refused<std::string>(json_fault::control_character);
    return {std::move(s)};
}

}  // namespace gw
