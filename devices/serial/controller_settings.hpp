#pragma once
// Settings of one controller (one serial port). A plain value; gateway/config/config.cpp fills it.

#include <chrono>
#include <cstddef>
#include <string>

namespace gw::devices {

struct controller_settings {
    std::string id;           // "stage1": logger "ms2000.stage1", and the id in every event
    std::string port;         // "/dev/ttyUSB0" or a stable symlink
    unsigned baud = 9600;     // 9600, 19200, 28800, 38400, 57600, 115200
    std::string report_port;  // optional SERIAL OUT port of the TTL_REPORT module ("" = none)

    // Positions and busy state are polled at this interval; zero disables polling.
    std::chrono::milliseconds poll_interval{100};
    // While the stage is idle and the only commands since the last poll round only read (WHERE,
    // STATUS, queries), a round starts only this long after the previous one: a client's commands
    // then rarely wait behind a poll. Anything that may move the stage brings back poll_interval.
    std::chrono::milliseconds idle_poll_interval{500};
    // Such an idle round also waits while a client keeps the line busy, its next command following
    // the last answer within this pause, for at most another idle_poll_interval: a client's commands
    // in a loop then wait behind a poll half as often.
    std::chrono::milliseconds client_pause{5};
    // The controller's error log (DU Y) is read when it connects, when its report stream has gone
    // quiet after frames, after a move or a refused command, and at least this often; zero: only on
    // those occasions. All but the first ride the poll timer, so none while polling is off. Like polls,
    // reads wait behind user commands.
    std::chrono::milliseconds error_log_interval{10000};
    std::chrono::milliseconds command_timeout{1000};
    std::chrono::milliseconds long_reply_timeout{5000};  // SS Z, BU X, INFO
    // Resynchronisation after a timeout, a reply that does not fit or unexpected bytes: the line must
    // stay quiet this long, then a V probe must be answered, then the line must stay quiet again
    // (devices/serial/README.md, "Reply matching").
    std::chrono::milliseconds resync_delay{100};
    // Probes that may fail (timeout, wrong answer, noise after the answer) before the connection is
    // reset, and the longest a resynchronisation may take; commands wait meanwhile.
    std::size_t resync_attempts = 10;
    std::chrono::milliseconds resync_timeout{10000};
    // A reply identical to the previous command's, arriving this soon after it, for another command,
    // may be that reply repeated (an adapter that sends a buffer twice, USB packets that arrive late).
    // It is held this long: if another line follows, it was the copy and is refused; if not, it is the
    // answer. Bare ":A" acks and ":N-<code>" errors are exempt: they repeat.
    std::chrono::milliseconds repeated_reply_window{50};
    std::size_t queue_limit = 64;  // user commands waiting (HALT and polls do not count)

    std::chrono::milliseconds reconnect_min{100};
    std::chrono::milliseconds reconnect_max{5000};
    // The device node is checked this often, so a vanished adapter is seen even without I/O.
    std::chrono::milliseconds presence_check{250};
};

}  // namespace gw::devices
