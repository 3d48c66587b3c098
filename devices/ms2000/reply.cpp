#include "devices/ms2000/reply.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

#include "devices/ms2000/ascii.hpp"
#include "devices/ms2000/error.hpp"

namespace gw::devices::ms2000 {

namespace {

std::string_view trim(std::string_view s) {
    while (!s.empty() && s.front() == ' ')
        s.remove_prefix(1);
    while (!s.empty() && s.back() == ' ')
        s.remove_suffix(1);
    return s;
}

std::vector<std::string_view> split_spaces(std::string_view s) {
    std::vector<std::string_view> tokens;
    while (!s.empty()) {
        const auto start = s.find_first_not_of(' ');
        if (start == std::string_view::npos) break;
        s.remove_prefix(start);
        const auto end = std::min(s.find(' '), s.size());
        tokens.push_back(s.substr(0, end));
        s.remove_prefix(end);
    }
    return tokens;
}

// The whole token as a finite number; from_chars also reads "inf" and "nan", which are not positions.
std::optional<double> to_number(std::string_view text) {
    double value = 0;
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc{} || ptr != text.data() + text.size() || !std::isfinite(value)) return std::nullopt;
    return value;
}

// "X=7.5", "X=" (empty text), "x=N".
std::optional<axis_value> to_axis_value(std::string_view token) {
    if (token.size() < 2 || !is_ascii_letter(token[0]) || token[1] != '=') return std::nullopt;
    axis_value v;
    v.axis = ascii_upper(token[0]);
    v.text = std::string(token.substr(2));
    v.number = to_number(v.text);
    return v;
}

boost::system::error_code unrecognized() {
    return make_error_code(error::unrecognized_reply);
}

// ":N-4" -> -4. Only "-" and digits are accepted after ":N".
std::optional<int> to_error_code(std::string_view body) {
    if (!body.starts_with(":N-") || body.size() < 4) return std::nullopt;
    const std::string_view digits = body.substr(3);
    for (char c : digits) {
        if (c < '0' || c > '9') return std::nullopt;
    }
    int code = 0;
    const std::string_view number = body.substr(2);  // "-4": from_chars reads the sign
    const auto [ptr, ec] = std::from_chars(number.data(), number.data() + number.size(), code);
    if (ec != std::errc{} || ptr != number.data() + number.size()) return std::nullopt;
    return code;
}

reply make(reply::kind what, std::string_view raw) {
    reply r;
    r.what = what;
    r.raw = std::string(raw);
    return r;
}

// The single-line shapes of reply_shape::standard; `body` is trimmed.
boost::system::result<reply> parse_standard(std::string_view body, std::string_view raw) {
    if (const auto code = to_error_code(body)) {
        reply r = make(reply::kind::error, raw);
        r.error_code = *code;
        return r;
    }
    reply r = make(reply::kind::ack, raw);
    if (body.starts_with(":A")) {
        // ":A", ":A 1234.5 0", ":A X=7.5 Y=7.5", ":A X=1 A", ":A F", ":A Version: USB-9.2p".
        const std::string_view rest = body.substr(2);
        if (!rest.empty() && rest.front() != ' ') return unrecognized();
        std::vector<std::string_view> tokens = split_spaces(rest);
        if (tokens.size() >= 2 && tokens.back() == "A" && to_axis_value(tokens[tokens.size() - 2])) {
            tokens.pop_back();
        }
        for (std::string_view token : tokens) {
            if (auto v = to_axis_value(token)) {
                r.axes.push_back(std::move(*v));
            } else {
                r.values.emplace_back(token);
            }
        }
        return r;
    }
    std::vector<std::string_view> tokens;
    if (body.starts_with(":")) {
        // ":X=50 Y=50 Z=50 A" (ACCEL, BACKLASH, WAIT, ERROR).
        tokens = split_spaces(body.substr(1));
        if (tokens.size() < 2 || tokens.back() != "A") return unrecognized();
    } else {
        // "X=10 :A", "X=10 Y=50 Z=50 F=0 :A" (LED).
        tokens = split_spaces(body);
        if (tokens.size() < 2 || tokens.back() != ":A") return unrecognized();
    }
    tokens.pop_back();
    for (std::string_view token : tokens) {
        auto v = to_axis_value(token);
        if (!v) return unrecognized();
        r.axes.push_back(std::move(*v));
    }
    return r;
}

boost::system::result<reply> parse_multiline(std::string_view line) {
    std::vector<std::string> lines;
    std::string_view rest = line;
    while (!rest.empty()) {
        const auto end = std::min(rest.find('\r'), rest.size());
        // Leading spaces are kept: INFO is two columns split at character 33.
        std::string_view one = rest.substr(0, end);
        while (!one.empty() && one.back() == ' ')
            one.remove_suffix(1);
        if (!trim(one).empty()) lines.emplace_back(one);
        rest.remove_prefix(std::min(end + 1, rest.size()));
    }
    if (lines.empty()) return unrecognized();
    // A single ":A .." or ":N-1" line is a normal reply (the command was refused or is not multi-line).
    if (lines.size() == 1 && trim(lines.front()).starts_with(":")) {
        return parse_standard(trim(lines.front()), line);
    }
    reply r = make(reply::kind::text, line);
    r.lines = std::move(lines);
    return r;
}

}  // namespace

std::optional<double> reply::number(std::size_t index) const {
    if (index >= values.size()) return std::nullopt;
    return to_number(values[index]);
}

const axis_value* reply::axis(char letter) const {
    const char wanted = ascii_upper(letter);
    for (const axis_value& v : axes) {
        if (v.axis == wanted) return &v;
    }
    return nullptr;
}

boost::system::result<reply> parse_reply(reply_shape expected, std::string_view line) {
    const std::string_view body = trim(line);
    switch (expected) {
        case reply_shape::standard:
            return parse_standard(body, line);
        case reply_shape::status: {
            // "N" / "B", no colon.
            if (body == "N" || body == "B") {
                reply r = make(reply::kind::status, line);
                r.busy = body == "B";
                return r;
            }
            if (const auto code = to_error_code(body)) {
                reply r = make(reply::kind::error, line);
                r.error_code = *code;
                return r;
            }
            return unrecognized();
        }
        case reply_shape::multiline:
            return parse_multiline(line);
        case reply_shape::status_bytes: {
            // ":" then raw bytes, kept only in `raw` (reply_fits counts them); a byte may be a space.
            if (const auto code = to_error_code(body)) {
                reply r = make(reply::kind::error, line);
                r.error_code = *code;
                return r;
            }
            if (line.size() >= 2 && line.front() == ':') return make(reply::kind::ack, line);
            return unrecognized();
        }
        case reply_shape::two_phase: {
            // ":" then "A" after the flash write; the framer may hand over ":A" or, if the ":" was
            // consumed on its own, "A".
            if (body == ":A" || body == "A") return make(reply::kind::ack, line);
            if (const auto code = to_error_code(body)) {
                reply r = make(reply::kind::error, line);
                r.error_code = *code;
                return r;
            }
            return unrecognized();
        }
    }
    return unrecognized();
}

std::optional<std::string> parse_version(const reply& r) {
    if (r.what != reply::kind::ack || r.values.empty()) return std::nullopt;
    std::string_view version;
    if (r.values[0] == "Version:" && r.values.size() >= 2) {
        // ":A Version: USB-9.50" -> "9.50" (the interface name before the '-').
        version = r.values[1];
        const auto dash = version.rfind('-');
        if (dash != std::string_view::npos) version.remove_prefix(dash + 1);
    } else if (r.values[0].size() >= 2 && (r.values[0][0] == 'v' || r.values[0][0] == 'V')) {
        version = std::string_view(r.values[0]).substr(1);  // ":A v9.54"
    }
    if (version.empty() || version[0] < '0' || version[0] > '9') return std::nullopt;
    return std::string(version);
}

std::optional<position_report_line> parse_position_report(std::string_view line) {
    line = trim(line);
    if (!line.starts_with("T:")) return std::nullopt;
    const std::vector<std::string_view> tokens = split_spaces(line.substr(2));
    if (tokens.empty()) return std::nullopt;
    position_report_line report;
    const auto ms = to_number(tokens[0]);
    if (!ms) return std::nullopt;
    report.milliseconds = *ms;
    for (std::size_t i = 1; i < tokens.size(); ++i) {
        const auto p = to_number(tokens[i]);
        if (!p) return std::nullopt;
        report.positions.push_back(*p);
    }
    return report;
}

}  // namespace gw::devices::ms2000
