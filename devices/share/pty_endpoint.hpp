#pragma once
// The shared pseudo-terminal of one controller: a pty pair whose slave is linked at the configured path,
// so that a program opens it as it would open the controller's serial port. The gateway keeps the
// master; the slave is only held by the programs that open it, so the master reports a hang-up while
// none does and the port can tell when a program arrives and leaves (program_present).

#include <string>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/posix/stream_descriptor.hpp>
#include <boost/asio/strand.hpp>

#include "devices/share/share_settings.hpp"

namespace gw::devices::share {

class pty_endpoint {
  public:
    explicit pty_endpoint(const boost::asio::strand<boost::asio::any_io_executor>& strand);
    ~pty_endpoint();
    pty_endpoint(const pty_endpoint&) = delete;
    pty_endpoint& operator=(const pty_endpoint&) = delete;

    // Creates the pty (raw: no echo, no line editing, so replies are never read back as commands), sets
    // the slave's mode and group, and links it at settings.pty (replacing a symlink there, never a
    // file). Returns "" or why it could not; `warning` gets what did not work but does not stop it
    // (a group that cannot be set).
    std::string open(const share_settings& settings, std::string& warning);
    // Closes the master (programs that hold the slave see a hang-up) and removes the link if it is still
    // the one made by open().
    void close();

    bool is_open() const { return master_.is_open(); }
    // A program holds the slave open (the master reports no hang-up).
    bool program_present();
    boost::asio::posix::stream_descriptor& master() { return master_; }
    const std::string& slave_name() const { return slave_name_; }

  private:
    boost::asio::posix::stream_descriptor master_;
    std::string slave_name_;  // /dev/pts/N
    std::string link_;        // the path linked to it
};

}  // namespace gw::devices::share
