#include "gateway/jobs/job_commands.hpp"

#include <cctype>
#include <charconv>
#include <stdexcept>

namespace gw::jobs {

namespace ms = devices::ms2000;

std::string text_of(const ms::command& c) {
    std::string s = c.wire;
    if (!s.empty() && s.back() == '\r') s.pop_back();
    return s;
}

ms::argument bare_arg(char letter) {
    return {letter, ms::argument::op::bare};
}

ms::command typed_command(std::string_view verb, std::span<const ms::argument> args) {
    auto c = ms::make_command(verb, args);
    if (!c)
        throw std::invalid_argument("cannot build a \"" + std::string(verb) +
                                    "\" command: " + c.error().message());
    return std::move(*c);
}

ms::command typed_command(std::string_view verb, std::initializer_list<ms::argument> args) {
    return typed_command(verb, std::span<const ms::argument>(args.begin(), args.size()));
}

ms::command typed_command(std::string_view verb) {
    return typed_command(verb, std::span<const ms::argument>{});
}

ms::command ttl_output(bool high) {
    return typed_command("TTL", {set_arg('Y', high ? 1 : 0, 0)});
}

ms::command ttl_in0(int mode) {
    return typed_command("TTL", {set_arg('X', mode, 0)});
}

ms::argument set_arg(char letter, double value, int decimals) {
    return {letter, ms::argument::op::set, value, decimals};
}

std::string command_text(std::string_view verb, std::span<const ms::argument> args) {
    auto c = ms::make_command(verb, args);
    return c ? text_of(*c) : std::string(verb);
}

std::string command_text(std::string_view verb, std::initializer_list<ms::argument> args) {
    return command_text(verb, std::span<const ms::argument>(args.begin(), args.size()));
}

std::string ttl_in0_command(int mode) {
    return command_text("TTL", {set_arg('X', mode, 0)});
}

std::string move_text(std::span<const ms::axis_position> to) {
    auto c = ms::move(to);
    return c ? text_of(*c) : "M";
}

std::string query_text(std::string_view verb, std::string_view letters) {
    return text_of(ms::query(verb, letters));
}

std::map<char, double> values_set(std::string_view line, std::string_view verb) {
    std::map<char, double> out;
    if (!line.starts_with(verb) || line.size() == verb.size() || line[verb.size()] != ' ') return out;
    std::string_view rest = line.substr(verb.size());
    while (!rest.empty()) {
        const auto start = rest.find_first_not_of(' ');
        if (start == std::string_view::npos) break;
        rest.remove_prefix(start);
        const auto token = rest.substr(0, rest.find(' '));
        rest.remove_prefix(token.size());
        // "X=1.5": a letter, "=", a number; other arguments set nothing.
        if (token.size() < 3 || !std::isalpha(static_cast<unsigned char>(token[0])) || token[1] != '=')
            continue;
        double value = 0;
        const auto number = token.substr(2);
        const auto [end, ec] = std::from_chars(number.data(), number.data() + number.size(), value);
        if (ec != std::errc{} || end != number.data() + number.size()) continue;
        out[static_cast<char>(std::toupper(static_cast<unsigned char>(token[0])))] = value;
    }
    return out;
}

bool has_module(const devices::controller_snapshot& s, ms::module m) {
    return s.identity && s.identity->build.has(m);
}

int axis_index(const devices::controller_snapshot& s, char letter) {
    for (std::size_t i = 0; i < s.axes.size(); ++i)
        if (s.axes[i].axis == letter) return static_cast<int>(i);
    return -1;
}

std::string motor_axes(const devices::controller_snapshot& s) {
    std::string out;
    for (const auto& a : s.axes)
        out += a.axis;
    return out;
}

}  // namespace gw::jobs
