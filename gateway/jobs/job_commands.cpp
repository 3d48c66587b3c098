#include "gateway/jobs/job_commands.hpp"

namespace gw::jobs {

namespace ms = devices::ms2000;

namespace {

std::string wire_text(const ms::command& c) {
    std::string s = c.wire;
    if (!s.empty() && s.back() == '\r') s.pop_back();
    return s;
}

}  // namespace

ms::argument set_arg(char letter, double value, int decimals) {
    return {letter, ms::argument::op::set, value, decimals};
}

std::string command_text(std::string_view verb, std::span<const ms::argument> args) {
    auto c = ms::make_command(verb, args);
    return c ? wire_text(*c) : std::string(verb);
}

std::string command_text(std::string_view verb, std::initializer_list<ms::argument> args) {
    return command_text(verb, std::span<const ms::argument>(args.begin(), args.size()));
}

std::string move_text(std::span<const ms::axis_position> to) {
    auto c = ms::move(to);
    return c ? wire_text(*c) : "M";
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
