#include "devices/ms2000/identify_answer.hpp"

#include <vector>

#include "devices/ms2000/line_framer.hpp"
#include "devices/ms2000/reply.hpp"
#include "devices/ms2000/reply_check.hpp"

namespace gw::devices::ms2000 {

namespace {

// The first framed line of `bytes`, if a CR LF ended one.
std::optional<std::string> first_line(std::string_view bytes) {
    line_framer framer;
    std::vector<std::string> lines;
    framer.feed(bytes, lines);
    if (lines.empty()) return std::nullopt;
    return std::move(lines.front());
}

}  // namespace

bool has_complete_line(std::string_view bytes) {
    return bytes.find("\r\n") != std::string_view::npos;
}

version_answer classify_version_answer(std::string_view bytes) {
    version_answer a;
    if (bytes.empty()) return a;
    a.what = version_answer::kind::other;
    a.complete = has_complete_line(bytes);
    auto line = first_line(bytes);
    if (!line) return a;
    if (!is_reply_text(*line)) return a;
    auto r = parse_reply(reply_shape::standard, *line);
    if (!r) return a;
    auto version = parse_version(*r);
    if (!version) return a;
    // ":A Version: USB-9.52" is the MS-2000's; a Tiger answers plain V with ":A v3.45" (§2.7, Tiger vs
    // MS-2000).
    a.what = r->values.front() == "Version:" ? version_answer::kind::ms2000 : version_answer::kind::tiger;
    a.version = std::move(*version);
    a.line = std::move(*line);
    return a;
}

std::optional<build_info> parse_build_answer(std::string_view bytes) {
    auto line = first_line(bytes);
    if (!line || !is_reply_text(*line)) return std::nullopt;
    auto r = parse_reply(reply_shape::multiline, *line);
    if (!r || r->what != reply::kind::text) return std::nullopt;
    auto build = parse_build_x(*line);
    if (!build) return std::nullopt;
    return std::move(*build);
}

}  // namespace gw::devices::ms2000
