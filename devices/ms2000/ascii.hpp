#pragma once
// ASCII character tests for the protocol's parsers. The controller speaks ASCII only, and <cctype>
// depends on the C locale, so the parsers use these (and the HTTP header readers, whose lists are
// ASCII too).

#include <string_view>

namespace gw::devices::ms2000 {

constexpr bool is_ascii_letter(char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z');
}

constexpr char ascii_upper(char c) {
    return (c >= 'a' && c <= 'z') ? static_cast<char>(c - 'a' + 'A') : c;
}

// Without the spaces and tabs at either end.
constexpr std::string_view trim_blanks(std::string_view s) {
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t'))
        s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t'))
        s.remove_suffix(1);
    return s;
}

}  // namespace gw::devices::ms2000
