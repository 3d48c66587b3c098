#pragma once
// Opens a shared port's TCP listener (the command port and the report port): bound with reuse_address,
// so a restarted gateway takes its port back at once, and listening.

#include <boost/asio/ip/tcp.hpp>
#include <boost/system/error_code.hpp>

namespace gw::devices::share {

inline boost::system::error_code open_listener(boost::asio::ip::tcp::acceptor& acceptor,
                                               const boost::asio::ip::tcp::endpoint& at) {
    boost::system::error_code ec;
    if (acceptor.open(at.protocol(), ec); ec) return ec;
    acceptor.set_option(boost::asio::ip::tcp::acceptor::reuse_address(true), ec);
    if (acceptor.bind(at, ec); ec) return ec;
    acceptor.listen(boost::asio::socket_base::max_listen_connections, ec);
    return ec;
}

}  // namespace gw::devices::share
