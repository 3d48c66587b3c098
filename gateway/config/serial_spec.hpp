#pragma once
// Parses the --serial flag: "ID=PATH[@BAUD][,report=PATH]" ("stage1=/dev/ttyUSB0@115200").
// Pure; the config file (issue 3) will replace it as the main way to describe controllers.

#include <string>
#include <string_view>

#include <boost/system/result.hpp>

#include "devices/serial/controller_settings.hpp"

namespace gw {

// The error is a sentence naming what is wrong ("baud must be one of ...").
boost::system::result<devices::controller_settings, std::string> parse_serial_spec(std::string_view spec);

}  // namespace gw
