#pragma once
// Line-based control of running simulators for tests and demos, on a Unix domain socket:
//   "pulse"            one TTL edge on IN0                      -> "ok"
//   "pulse N RATE_HZ"  N edges at RATE_HZ (simulated time)      -> "ok"
//   "unplug" / "replug"                                          -> "ok"
//   "drop-next" / "corrupt-next" / "delay-next MS"               -> "ok"
//   "split-next MS"    the next reply in two writes, MS apart    -> "ok"
//   "highbit-next"     one byte of the next reply with bit 7 set -> "ok"
//   "echo-next"        the next reply sent twice                 -> "ok"
//   "garbage N"        N random bytes (never CR/LF) on the port  -> "ok"
//   "refuse-next VERB CODE"  the next VERB command gets ":N<CODE>" (CODE -1..-99), not run -> "ok"
//   "state"            the simulator's state as one JSON line
//   "list"             the simulator names, space-separated
//   "help"             the command list on one line
// With several simulators, a command may start with a simulator name ("stage2 pulse"); without
// one it goes to the first. Errors answer "error: <reason>". Every answer is exactly one line.

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/local/stream_protocol.hpp>

#include "devices/sim/simulator.hpp"

namespace gw::devices::sim {

class control_channel : public std::enable_shared_from_this<control_channel> {
  public:
    control_channel(boost::asio::any_io_executor executor, std::string socket_path,
                    std::vector<std::shared_ptr<simulator>> simulators);

    // Binds (removing a stale socket file first) and starts accepting. Throws std::system_error.
    void start();
    void stop();

    // One command line -> one answer line (without the newline). Thread-safe (simulator API is).
    std::string execute(std::string_view line) const;
    static std::string help_text();

    const std::string& path() const { return path_; }

  private:
    void accept();

    boost::asio::any_io_executor executor_;
    std::string path_;
    std::vector<std::shared_ptr<simulator>> simulators_;
    boost::asio::local::stream_protocol::acceptor acceptor_;
};

}  // namespace gw::devices::sim
