#pragma once
// The controller's own error log (DU Y), read in the gaps between client commands.
//
// When: as the last step of identification, when the report stream goes quiet after frames (the
// controller logs error 87 for each frame it could not send), when the poll sees a move end (a clamped
// target logs 34/35), after a client command the controller refused, and every error_log_interval.
// Clearing (DU X) is how the next read tells new codes from old ones, but a code logged between the read
// and the clear would be lost: so the log is cleared only while the stage is idle and the report stream
// quiet, or when it is filling up (the firmware keeps a bounded log). Meanwhile each read publishes what
// follows the codes already seen. Owns the snapshot's error log fields. Used on the controller's strand.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include <boost/system/error_code.hpp>

#include "devices/ms2000/reply.hpp"
#include "devices/serial/command_queue.hpp"
#include "devices/serial/controller_settings.hpp"
#include "devices/serial/controller_snapshot.hpp"
#include "devices/serial/event_outlet.hpp"

namespace spdlog {
class logger;
}

namespace gw::devices {

class error_log_reader {
  public:
    error_log_reader(const controller_settings& settings, controller_snapshot& snapshot, event_outlet& outlet,
                     spdlog::logger& log);

    // A new connection: nothing read on it yet, and a firmware that refused DU Y is asked again.
    void reset();
    // The answer to the read that ends the identification (whatever it is, it does not fail that).
    void identification_read(boost::system::error_code ec, const ms2000::reply& r);

    // Occasions to read. A move ended or the controller refused a command: read at the next chance.
    void read_soon() { read_due_ = true; }
    // Report bytes arrived: once the stream has been quiet a while, the log is read.
    void note_report_bytes(std::chrono::steady_clock::time_point at);
    // On each poll tick: the schedule, and a report stream gone quiet.
    void note_occasions();

    // The next step (a read or a clear) when one is due; the link asks after the clients' commands.
    std::optional<queued_command> next_command();

  private:
    enum class step : std::uint8_t { idle, reading, clearing, unsupported };

    void on_read(boost::system::error_code ec, const ms2000::reply& r);
    void on_cleared(boost::system::error_code ec);
    bool clear_is_safe(std::size_t logged) const;
    void retry_step();  // a step held back (a HALT jumped in): due again

    const controller_settings& settings_;
    controller_snapshot& snapshot_;
    event_outlet& outlet_;
    spdlog::logger& log_;

    step step_ = step::idle;
    bool read_due_ = false;
    bool clear_due_ = false;
    std::vector<int> seen_;     // the codes read since the log was last cleared
    std::size_t failures_ = 0;  // reads in a row that got no usable answer
    std::chrono::steady_clock::time_point read_at_;
    // Report frames arrived since the log was last read: once the stream is quiet, it is read.
    bool report_activity_ = false;
    std::chrono::steady_clock::time_point last_report_bytes_;
};

}  // namespace gw::devices
