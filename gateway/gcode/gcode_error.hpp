#pragma once
// An error in a G-code program: where it is (1-based file line and column; 0 when the error is not
// tied to a place, e.g. bad options) and what is wrong. A program with an error moves nothing.

#include <string>

namespace gw::gcode {

struct gcode_error {
    int line = 0;
    int column = 0;
    std::string message;  // ASCII only: bytes outside printable ASCII are written as "byte 0xNN"

    bool operator==(const gcode_error&) const = default;
};

}  // namespace gw::gcode
