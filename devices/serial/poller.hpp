#pragma once
// The poll rounds that keep the snapshot's positions, busy flags and CRISP state fresh, and their pace.
//
// A round is "/", then "W <axes>" (the answer to "/" applied with the positions read after it, so a
// snapshot that says a move ended also says where it ended), then "RS <axis>?" per axis while "/" said
// busy, then "LK X?" on a controller with CRISP. At most one round is pending, and its steps wait
// behind client commands (the link asks for them last). Rounds start every poll_interval while the
// stage moves or after a command that may change something, and only every idle_poll_interval while
// it is idle and only reads ran; an idle round also yields to a client in a loop (client_pause), up to
// twice idle_poll_interval after the previous round. Used on the controller's strand only.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/system/error_code.hpp>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/reply.hpp"
#include "devices/serial/command_queue.hpp"
#include "devices/serial/controller_settings.hpp"
#include "devices/serial/controller_snapshot.hpp"
#include "devices/serial/event_outlet.hpp"

namespace spdlog {
class logger;
}

namespace gw::devices {

class poller {
  public:
    // What the poller asks of the controller that owns it.
    class owner {
      public:
        // A strong reference for the pending tick: the controller outlives it.
        virtual std::shared_ptr<void> keep_alive() = 0;
        // Every poll_interval while connected, once the poller has decided whether a round is due: the
        // error log's occasions ride this tick, and the link is offered the work.
        virtual void poll_tick() = 0;
        // A round saw the stage stop (a target beyond a soft limit was clamped and logged: 34/35).
        virtual void move_ended() = 0;

      protected:
        ~owner() = default;
    };

    poller(const boost::asio::strand<boost::asio::any_io_executor>& strand,
           const controller_settings& settings, controller_snapshot& snapshot, event_outlet& outlet,
           spdlog::logger& log, owner& owner);

    // A new connection: a build that refused "LK X?" on the last one is asked again.
    void reset();
    // The controller was identified: a round at once, then the ticks.
    void start();
    // The connection ended: no round pending, no more ticks.
    void stop();

    // The next step of the round, when one is due; the link asks after the clients' commands.
    std::optional<queued_command> next_command();

    // A client's command finished on the wire. One that may change something brings back the fast pace;
    // an answer to "/" is the newest word on motion (and one that sees the end starts a round at once).
    void client_command_finished(const ms2000::command& cmd, boost::system::error_code ec,
                                 const ms2000::reply* reply);
    // A client's command completed: an idle round yields to a client that keeps the line busy.
    void client_answered() { last_client_answer_ = std::chrono::steady_clock::now(); }

  private:
    enum class step : std::uint8_t { idle, status, where, axis_status, crisp };

    void arm_timer();
    bool round_watches_change() const;
    bool round_wanted() const;       // see controller_settings::idle_poll_interval
    bool idle_round_yields() const;  // see controller_settings::client_pause
    void on_reply(step answered, std::size_t axis_index, boost::system::error_code ec,
                  const ms2000::reply& r);

    const controller_settings& settings_;
    controller_snapshot& snapshot_;
    event_outlet& outlet_;
    spdlog::logger& log_;
    owner& owner_;

    boost::asio::steady_timer timer_;
    std::uint64_t generation_ = 0;  // bumped by stop(), so that a tick already queued is ignored
    step step_ = step::idle;
    bool due_ = false;
    // For the idle pace: when the last round started, and whether a command that may move the stage (or
    // change what a poll reads) ran since.
    std::chrono::steady_clock::time_point last_round_;
    bool changed_since_round_ = true;
    std::chrono::steady_clock::time_point last_client_answer_{};
    std::size_t axis_ = 0;
    bool polled_busy_ = false;    // this round's answer to "/", applied with its positions
    bool crisp_refused_ = false;  // LK X? answered :N- on this connection: not polled again
};

}  // namespace gw::devices
