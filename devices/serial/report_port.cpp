#include "devices/serial/report_port.hpp"

#include <span>

#include <boost/asio/bind_executor.hpp>
#include <boost/asio/buffer.hpp>
#include <spdlog/spdlog.h>

namespace gw::devices {
namespace net = boost::asio;
using boost::system::error_code;
using std::chrono::steady_clock;
using std::chrono::system_clock;

report_port::report_port(const net::strand<net::any_io_executor>& strand, const controller_settings& settings,
                         controller_snapshot& snapshot, event_outlet& outlet, spdlog::logger& log,
                         owner& owner)
    : strand_(strand),
      settings_(settings),
      snapshot_(snapshot),
      outlet_(outlet),
      log_(log),
      owner_(owner),
      port_(strand) {
    snapshot_.report = settings_.report_port.empty() ? report_port_state::none : report_port_state::closed;
}

void report_port::open() {
    if (settings_.report_port.empty() || port_.is_open()) return;
    if (auto ec = port_.open(settings_.report_port, settings_.baud)) {
        outlet_.log_error("cannot open report port", ec);
        snapshot_.report = report_port_state::closed;
        return;
    }
    decoder_.emplace(ms2000::report_format::binary, snapshot_.axes.size());
    snapshot_.report = report_port_state::open;
    log_.info("report port {} open", settings_.report_port);
    read(++generation_);
    outlet_.publish_snapshot();
}

void report_port::close() {
    ++generation_;
    port_.close();
    if (!settings_.report_port.empty()) snapshot_.report = report_port_state::closed;
}

void report_port::read(std::uint64_t generation) {
    port_.stream().async_read_some(
        net::buffer(buffer_),
        net::bind_executor(strand_, [this, alive = owner_.keep_alive(), generation](
                                        error_code ec, std::size_t n) { on_read(generation, ec, n); }));
}

void report_port::on_read(std::uint64_t generation, error_code ec, std::size_t bytes) {
    if (generation != generation_) return;
    if (ec) {
        outlet_.log_error("report port read", ec);
        close();
        outlet_.publish_snapshot();
        return;
    }
    try {
        on_bytes(bytes);
    } catch (const std::exception& e) {
        owner_.contain("reading the report port", e);
    }
    if (generation != generation_) return;
    read(generation);
}

void report_port::on_bytes(std::size_t bytes) {
    const auto steady_now = steady_clock::now();
    const auto system_now = system_clock::now();
    if (tap_) tap_(std::string_view(reinterpret_cast<const char*>(buffer_.data()), bytes));
    frames_.clear();
    decoder_->feed(std::span<const std::uint8_t>(buffer_.data(), bytes), frames_);
    owner_.report_bytes_arrived(steady_now);
    for (const auto& frame : frames_) {
        report_event event;
        event.controller_id = settings_.id;
        event.sequence = ++sequence_;
        event.steady_time = steady_now;
        event.system_time = system_now;
        event.bytes_skipped = decoder_->bytes_skipped();
        for (const auto& count : frame.axes) {
            report_event::axis a{count.axis, count.count, std::nullopt};
            if (const auto* state = snapshot_.axis(count.axis);
                state && state->counts_per_mm && *state->counts_per_mm != 0) {
                a.position_um = count.count / *state->counts_per_mm * 1000.0;
            }
            event.axes.push_back(a);
        }
        if (log_.should_log(spdlog::level::trace)) log_.trace("report #{}", event.sequence);
        outlet_.report(event);
    }
}

}  // namespace gw::devices
