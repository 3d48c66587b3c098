#pragma once
// Parses one framed reply line (without CR LF). Pure: no I/O. The only place where replies are read.
//   ":A"  ":A "                      -> ack
//   ":A 1234.5 432.1 0 "             -> ack, values {"1234.5", "432.1", "0"}
//   ":A X=7.5 Y=7.5"                 -> ack, axes {X 7.5, Y 7.5}
//   ":X=50 Y=50 Z=50 A"              -> ack, axes (ACCEL, BACKLASH, WAIT, ERROR shape)
//   "X=10 :A"                        -> ack, axes (LED X? shape)
//   ":N-4"                           -> error, error_code -4 (signed, never an offset)
//   "N" / "B"                        -> status (reply_shape::status only)
//   "STD_XYZ\rMotor Axes: X Y Z\r.." -> text, lines (reply_shape::multiline)
//   ":A" after ":" (SS Z)            -> ack (reply_shape::two_phase)
//   ":" + raw bytes (RB X Y)          -> ack, the bytes only in raw (reply_shape::status_bytes)

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <boost/system/result.hpp>

#include "devices/ms2000/command.hpp"

namespace gw::devices::ms2000 {

struct axis_value {
    char axis = 'X';               // upper case
    std::string text;              // as received: "7.500000", "N", "" for "X="
    std::optional<double> number;  // when text is a number
};

struct reply {
    enum class kind : std::uint8_t { ack, error, status, text };
    kind what = kind::ack;
    int error_code = 0;               // what == error: the signed code (-1, -21, ...)
    bool busy = false;                // what == status: "B"
    std::vector<std::string> values;  // positional tokens after ":A"
    std::vector<axis_value> axes;     // "X=.." tokens, in reply order
    std::vector<std::string> lines;   // what == text: lines split on CR, blank lines dropped
    std::string raw;                  // the line as received

    std::optional<double> number(std::size_t index) const;  // values[index] as a number
    const axis_value* axis(char letter) const;              // case-insensitive, nullptr if absent
};

// Returns error::unrecognized_reply for a line that fits no shape of `expected`.
boost::system::result<reply> parse_reply(reply_shape expected, std::string_view line);

// ":A Version: USB-9.50 " -> "9.50"; ":A v9.54" -> "9.54"; nullopt otherwise.
std::optional<std::string> parse_version(const reply& r);

// Unsolicited serial position report (TTL IN0 mode 5 / RT M+): "T:   400    0.0    0.1".
struct position_report_line {
    double milliseconds = 0;
    std::vector<double> positions;  // tenths of a micron, in the order of the RM Y axis mask
};
std::optional<position_report_line> parse_position_report(std::string_view line);

}  // namespace gw::devices::ms2000
