#pragma once
// Reads what a port answered to the identification queries of a port probe (V, then BU X): is it an
// MS-2000, and which. Pure: no I/O. The bytes are whatever came back before the probe's deadline, at
// one baud rate; they are data, not text (noise at a wrong baud rate is the common case).
//   ":A Version: USB-9.52 \r\n"  -> ms2000, version "9.52"
//   ":A v3.45\r\n"               -> tiger (an ASI Tiger answers V that way; not an MS-2000)
//   "\x8f\xfe..."                 -> other (noise: another device, or a baud rate that does not match)
//   ""                           -> silent

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "devices/ms2000/build_info.hpp"

namespace gw::devices::ms2000 {

struct version_answer {
    enum class kind : std::uint8_t { silent, ms2000, tiger, other };
    kind what = kind::silent;
    std::string version;    // ms2000 / tiger: "9.52" (parse_version)
    std::string line;       // ms2000 / tiger: the reply line as received (printable ASCII)
    bool complete = false;  // a whole line (CR LF) arrived: waiting longer would not change the verdict
};

// The verdict on the bytes received after "V\r". The first complete line decides; bytes without a
// line end are `other` (incomplete: the caller may wait for more).
version_answer classify_version_answer(std::string_view bytes);

// The build of a BU X answer (the framed text up to CR LF), or nullopt for an error reply (":N-1",
// firmware without BU X), noise, or an incomplete answer. Uses parse_build_x.
std::optional<build_info> parse_build_answer(std::string_view bytes);

// True once `bytes` hold a whole reply line (CR LF seen): the probe can stop waiting.
bool has_complete_line(std::string_view bytes);

}  // namespace gw::devices::ms2000
