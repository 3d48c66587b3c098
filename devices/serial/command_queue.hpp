#pragma once
// The commands waiting for a controller's link, in the order they are served: HALTs, then the
// driver's own (identification, settings read back), then the clients' (first come, first served,
// bounded by queue_limit). It also counts the HALTs accepted, for the guarded commands that must never
// follow a HALT their caller did not see. Another producer of commands (a shared port) is one more
// queue here. Used on the controller's strand only; halts_accepted() from any thread.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <boost/asio/any_completion_handler.hpp>
#include <boost/system/error_code.hpp>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/error.hpp"
#include "devices/ms2000/reply.hpp"

namespace gw::devices {

using command_completion =
    boost::asio::any_completion_handler<void(boost::system::error_code, ms2000::reply)>;
using internal_handler = std::function<void(boost::system::error_code, const ms2000::reply&)>;

// The command never got an answer because the port or the controller went away (or was stopped): the
// driver's own continuations end there.
inline bool command_aborted(boost::system::error_code ec) {
    return ec == ms2000::error::disconnected || ec == ms2000::error::cancelled ||
           ec == ms2000::error::not_connected;
}

// Built in place and moved by construction only: Boost 1.81's any_completion_handler cannot be
// move-assigned (its operator= wraps the handler in another one, recursively).
struct queued_command {
    ms2000::command cmd{};
    std::string request_id{};
    command_completion user{};    // set for a client's command
    internal_handler internal{};  // set for the driver's own (identify, poll, error log, resync probe)
    // Set for background work (a poll step, an error log step): held back while the link gets back in
    // step, it is not requeued but dropped, and this tells its source to offer it again in its turn.
    std::function<void()> held_back{};
    bool probe = false;   // the resynchronisation probe
    bool resent = false;  // a HALT sent again after the link was resynchronised
    // async_guarded_command: the halts_accepted() its caller last saw.
    std::optional<std::uint64_t> halts_seen{};
};

class command_queue {
  public:
    explicit command_queue(std::size_t limit) : limit_(limit) {}

    // A HALT was accepted (counted even if it is then refused: the intent to stop counts). Returns the
    // guarded commands that were waiting: their callers decided on them before this HALT.
    std::vector<queued_command> accept_halt();
    // A guarded command whose caller has not seen every HALT accepted.
    bool missed_halt(const queued_command& job) const {
        return job.halts_seen && *job.halts_seen != halts_accepted();
    }
    std::uint64_t halts_accepted() const { return halts_accepted_.load(std::memory_order_acquire); }

    // A HALT or a client's command; false (and `job` left as it was) when its queue is full.
    bool push(queued_command& job);
    void push_internal(queued_command job) { internal_.push_back(std::move(job)); }
    // A command taken but not written (held back, or a HALT to send again): first of its kind again.
    void push_front(queued_command job);
    std::optional<queued_command> pop();
    // Everything waiting, in the order of service; the queue is left empty.
    std::vector<queued_command> take_all();

    // A HALT waits that has not been written yet: it goes out even while the link is out of step.
    bool unsent_halt_waiting() const { return !halts_.empty() && !halts_.front().resent; }

  private:
    std::deque<queued_command>& queue_of(const queued_command& job);

    std::size_t limit_;
    std::deque<queued_command> halts_;
    std::deque<queued_command> internal_;
    std::deque<queued_command> user_;
    std::atomic<std::uint64_t> halts_accepted_{0};  // written on the strand only
};

}  // namespace gw::devices
