#include "api/common/printable_text.hpp"

#include <algorithm>

namespace gw::api {

namespace {

constexpr std::size_t max_shown_chars = 64;

bool all_in(std::string_view s, unsigned char lowest) {
    return std::all_of(s.begin(), s.end(), [lowest](char c) {
        const auto u = static_cast<unsigned char>(c);
        return u >= lowest && u <= 0x7e;
    });
}

}  // namespace

bool is_printable_word(std::string_view s) {
    return all_in(s, 0x21);
}

bool is_printable_label(std::string_view s) {
    return all_in(s, 0x20);
}

std::string shown_in_message(std::string_view s) {
    if (s.size() <= max_shown_chars && is_printable_word(s)) return std::string(s);
    return "...";
}

}  // namespace gw::api
