#pragma once
// A simulated MS-2000 controller exposed on a pseudo-terminal, for users without hardware and for
// every test. One simulator = one main port (pty + stable symlink) and optionally one SERIAL OUT
// report port. All state lives on one strand of the caller's executor; the public methods may be
// called from any thread (they post to the strand), except start() and stop(), which must not race
// with other calls on the same object: call start() before handing the simulator to other threads,
// and stop() (or destroy it) after they are done, while its io_context still exists.
//
//   auto sim = std::make_shared<simulator>(io.get_executor(), preset("full").value());
//   sim->start();                       // throws std::system_error if the pty cannot be opened
//   open(sim->port_path(), ...);        // like a real client
//   sim->ttl_pulse();                   // a TTL edge on IN0
//   sim->stop();

#include <chrono>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>

#include <boost/asio/any_io_executor.hpp>

#include "devices/sim/sim_config.hpp"

namespace gw::devices::sim {

class simulator_impl;

class simulator : public std::enable_shared_from_this<simulator> {
  public:
    using executor_type = boost::asio::any_io_executor;

    simulator(executor_type executor, sim_config config);
    ~simulator();
    simulator(const simulator&) = delete;
    simulator& operator=(const simulator&) = delete;

    // Opens the pty pair(s), creates the symlinks and starts reading. Throws std::system_error.
    void start();
    // Closes the ptys, removes the symlinks, cancels timers. Idempotent.
    void stop();

    const sim_config& config() const { return config_; }
    // The stable symlink a client opens ("/tmp/ms2000-sim/ms2000/port").
    const std::string& port_path() const { return port_link_; }
    // The report port symlink; empty when the config has no report port.
    const std::string& report_port_path() const { return report_link_; }
    // The current /dev/pts/N behind port_path() (changes after replug()).
    std::string device_path() const;

    // Hardware events.
    void ttl_pulse();                                         // one TTL edge on IN0
    void ttl_pulse_train(std::size_t count, double rate_hz);  // rate in simulated time
    void unplug();  // closes the pty master (client sees EIO/HUP) and removes the symlink
    void replug();  // a new pty, the symlink re-pointed to it

    // Fault injection, applied to the next reply on the main port.
    void drop_next_reply();
    void corrupt_next_reply();                               // first byte changed: unparseable line
    void delay_next_reply(std::chrono::milliseconds by);     // real (unscaled) milliseconds
    void emit_garbage(std::size_t bytes);                    // random bytes, never CR or LF
    void split_next_reply(std::chrono::milliseconds pause);  // two writes, a real pause between
    void high_bit_next_reply();                              // one byte of it with bit 7 set
    void echo_next_reply();                                  // sent twice
    // The next command with this verb ("MOVE", "CCB"; abbreviations count) is answered ":N<code>"
    // (code negative, ms2000/error.hpp) and not carried out.
    void refuse_next_command(std::string verb, int code);

    // A JSON snapshot of the model (positions, targets, busy, modules, TTL modes, ring buffer,
    // array, scan, error buffer) plus I/O counters. Synchronous; safe from any thread.
    std::string state_json() const;

  private:
    executor_type executor_;
    sim_config config_;
    std::string port_link_;
    std::string report_link_;
    std::shared_ptr<simulator_impl> impl_;
};

}  // namespace gw::devices::sim
