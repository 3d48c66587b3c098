#pragma once
// An mqtt:// URL of a local port nobody listens on: a broker that refuses every connection.

#include <string>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>

namespace gw::test {

inline std::string closed_broker_url() {
    boost::asio::io_context io;
    boost::asio::ip::tcp::acceptor a(io, {boost::asio::ip::make_address("127.0.0.1"), 0});
    const auto port = a.local_endpoint().port();
    a.close();
    return "mqtt://127.0.0.1:" + std::to_string(port);
}

}  // namespace gw::test
