#pragma once
// Writes bytes to a pty master at the simulated baud rate: 10 bits per byte (8N1), scaled by the
// simulator's time scale. Every entry may carry an earliest time (a delayed reply, a report frame
// scheduled after the transmit delay); entries leave strictly in order. One write in flight, on the
// owner's strand; never blocks.
// The line keeps its own schedule: each chunk is due when the line has carried the bytes before it,
// not when the last write happened to complete. A timer that fires late on a loaded machine delays
// bytes but does not push every later byte back: the writer catches up, as the controller's UART,
// which does not wait for the host, would have sent them by then.

#include <chrono>
#include <cstddef>
#include <deque>
#include <memory>
#include <string>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/posix/stream_descriptor.hpp>
#include <boost/asio/steady_timer.hpp>

namespace gw::devices::sim {

class paced_writer : public std::enable_shared_from_this<paced_writer> {
  public:
    using clock = std::chrono::steady_clock;

    // `executor` must be the owner's strand.
    paced_writer(const boost::asio::any_io_executor& executor, unsigned baud, double time_scale);

    void attach(int master_fd);  // takes a dup of the descriptor
    void detach();               // closes it, drops queued bytes, cancels the timer

    // Bytes beyond max_queued_bytes are dropped (nobody is reading the port: a real UART would
    // send them into the void) and counted in dropped_bytes().
    static constexpr std::size_t max_queued_bytes = std::size_t{64} * 1024;
    // An entry with no earliest time starts when it is enqueued or when the line is free, whichever
    // is later. One whose earliest time is already past (a frame made late because the strand was
    // held up) is due at that time, so it goes out at once: the line catches up.
    void enqueue(std::string bytes, clock::time_point not_before = clock::time_point{});
    std::uint64_t dropped_bytes() const { return dropped_bytes_; }
    std::uint64_t bytes_written() const { return bytes_written_; }
    std::size_t queued_bytes() const;

  private:
    struct entry {
        std::string bytes;
        std::size_t offset = 0;
        clock::time_point not_before;
    };

    void pump();

    boost::asio::any_io_executor executor_;
    boost::asio::posix::stream_descriptor stream_;
    boost::asio::steady_timer timer_;
    std::deque<entry> queue_;
    clock::duration byte_time_;
    std::size_t chunk_bytes_;
    clock::time_point line_free_{};
    bool busy_ = false;
    std::uint64_t generation_ = 0;  // bumped by detach(); stale completions are ignored
    std::uint64_t bytes_written_ = 0;
    std::uint64_t dropped_bytes_ = 0;
};

}  // namespace gw::devices::sim
