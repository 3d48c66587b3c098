#pragma once
// Makes serial bytes printable for logs and traces: "W X\r" -> "W X\\r", 0x18 -> "\\x18".

#include <string>
#include <string_view>

namespace gw::devices {

std::string escape_control(std::string_view bytes);

}  // namespace gw::devices
