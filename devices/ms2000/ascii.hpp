#pragma once
// ASCII character tests for the protocol's parsers. The controller speaks ASCII only, and <cctype>
// depends on the C locale, so the parsers use these.

namespace gw::devices::ms2000 {

constexpr bool is_ascii_letter(char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z');
}

constexpr char ascii_upper(char c) {
    return (c >= 'a' && c <= 'z') ? static_cast<char>(c - 'a' + 'A') : c;
}

}  // namespace gw::devices::ms2000
