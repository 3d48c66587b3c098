#include "devices/ms2000/host_step_timing.hpp"

#include <algorithm>

namespace gw::devices::ms2000 {

namespace {

constexpr double bits_per_char = 10;                 // 8N1: start, eight data bits, stop
constexpr std::size_t command_terminator_chars = 1;  // CR
constexpr std::size_t reply_terminator_chars = 2;    // CR LF

}  // namespace

double command_round_trip_s(const host_link_timing& link, std::size_t command_chars,
                            std::size_t reply_chars) {
    const double chars =
        static_cast<double>(command_chars + command_terminator_chars + reply_chars + reply_terminator_chars);
    const double baud = std::max(1u, link.baud);
    return chars * bits_per_char / baud + std::max(0.0, link.turnaround_ms) / 1000.0;
}

double arrival_lag_s(const host_link_timing& link) {
    const double status = command_round_trip_s(link, status_chars, status_chars);
    const double cycle = std::max(0.0, link.arrival_poll_ms) / 1000.0 + status;
    return cycle / 2 + status;
}

double host_move_overhead_s(const host_link_timing& link, bool with_speed) {
    double s = command_round_trip_s(link, typical_move_chars) + arrival_lag_s(link);
    if (with_speed) s += command_round_trip_s(link, typical_speed_chars);
    return s;
}

}  // namespace gw::devices::ms2000
