#pragma once
// The TTL_REPORT module's SERIAL OUT port (controller_settings::report_port): opened once the
// controller is identified, read while it stays connected, its bytes decoded into frames and each frame
// published as a report_event. Owns the snapshot's `report` state. Used on the controller's strand only.

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/strand.hpp>
#include <boost/system/error_code.hpp>

#include "devices/ms2000/report_frame.hpp"
#include "devices/serial/controller_settings.hpp"
#include "devices/serial/controller_snapshot.hpp"
#include "devices/serial/event_outlet.hpp"
#include "devices/serial/serial_port.hpp"

namespace spdlog {
class logger;
}

namespace gw::devices {

class report_port {
  public:
    // What the report port asks of the controller that owns it.
    class owner {
      public:
        // A strong reference for a pending read: the controller outlives it.
        virtual std::shared_ptr<void> keep_alive() = 0;
        // Bytes arrived (the error log is read once the stream has gone quiet).
        virtual void report_bytes_arrived(std::chrono::steady_clock::time_point at) = 0;
        // Handling them threw: logged and counted, and the controller's connection reset.
        virtual void contain(const char* where, const std::exception& e) = 0;

      protected:
        ~owner() = default;
    };

    report_port(const boost::asio::strand<boost::asio::any_io_executor>& strand,
                const controller_settings& settings, controller_snapshot& snapshot, event_outlet& outlet,
                spdlog::logger& log, owner& owner);

    // Opens the port, if one is configured and it is not open, and reads it; the decoder expects the
    // snapshot's motor axes. A failed open leaves it closed (the caller tries again later).
    void open();
    void close();
    bool is_open() const { return port_.is_open(); }
    // Gets every byte read, unchanged, before it is decoded (a shared report port); empty: none.
    using byte_tap = std::function<void(std::string_view)>;
    void set_tap(byte_tap tap) { tap_ = std::move(tap); }

  private:
    void read(std::uint64_t generation);
    void on_read(std::uint64_t generation, boost::system::error_code ec, std::size_t bytes);
    void on_bytes(std::size_t bytes);

    boost::asio::strand<boost::asio::any_io_executor> strand_;
    const controller_settings& settings_;
    controller_snapshot& snapshot_;
    event_outlet& outlet_;
    spdlog::logger& log_;
    owner& owner_;

    serial_port port_;
    std::uint64_t generation_ = 0;  // bumped on every open and close, so old read handlers are ignored
    std::array<std::uint8_t, 512> buffer_{};
    std::optional<ms2000::report_decoder> decoder_;
    std::vector<ms2000::report_frame> frames_;
    std::uint64_t sequence_ = 0;
    byte_tap tap_;
};

}  // namespace gw::devices
