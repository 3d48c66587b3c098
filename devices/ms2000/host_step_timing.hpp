#pragma once
// What a host-driven step costs besides the motion itself, when the host sends each move and polls
// for its end (the gateway's `gcode` job, one MOVE per straight segment). Shared by the job planner
// (gateway/jobs/motion_model) and the G-code library's estimate (gateway/gcode), so both add the same
// overhead. Pure.
//
//   command round trip = (command + CR + reply + CR LF) * 10 bits / baud + turnaround
//   arrival lag        = poll cycle / 2 + STATUS round trip, poll cycle = poll interval + STATUS
//                        round trip: the stop falls anywhere in a cycle; the next STATUS notices it
//   host move overhead = [SPEED round trip] + MOVE round trip + arrival lag
// The turnaround (controller parsing plus the host's queue and timer latency) of 1 ms is a round
// figure that puts bench/gcode_trace.py's estimates within 3 % of the traces on the simulator (a pty
// at 115200 baud); a real controller's parsing is of the same order.

#include <cstddef>

namespace gw::devices::ms2000 {

struct host_link_timing {
    unsigned baud = 115200;
    double arrival_poll_ms = 20;  // STATUS interval while the host waits for a move to end
    double turnaround_ms = 1.0;   // per command, on top of the bytes on the wire
};

// Typical command lengths of a coordinated segment ("SPEED X=0.123456 Y=0.654321", "M X=12345.6
// Y=-6543.2") and of the replies (":A", the one-letter STATUS answer).
inline constexpr std::size_t typical_speed_chars = 27;
inline constexpr std::size_t typical_move_chars = 21;
inline constexpr std::size_t typical_reply_chars = 2;
inline constexpr std::size_t status_chars = 1;

// Seconds for one command of `command_chars` answered with `reply_chars` (terminators added here).
double command_round_trip_s(const host_link_timing& link, std::size_t command_chars,
                            std::size_t reply_chars = typical_reply_chars);
// Expected seconds from the end of a move (settled) until the host's STATUS poll reports it idle.
double arrival_lag_s(const host_link_timing& link);
// Overhead of one host-driven move: its MOVE, a SPEED before it when `with_speed`, and the arrival lag.
double host_move_overhead_s(const host_link_timing& link, bool with_speed);

}  // namespace gw::devices::ms2000
