#include "api/mqtt/tcp_nodelay.hpp"

#include <cstdint>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <gtest/gtest.h>

namespace gw::api {
namespace {

namespace net = boost::asio;
using tcp = net::ip::tcp;

bool nagle_off(tcp::socket& s) {
    tcp::no_delay option;
    s.get_option(option);
    return option.value();
}

// A listener on loopback, one client connected to it and the accepted end.
struct connected_pair {
    explicit connected_pair(net::io_context& io)
        : acceptor(io, tcp::endpoint(net::ip::address_v4::loopback(), 0)), client(io), accepted(io) {
        client.connect(acceptor.local_endpoint());
        acceptor.accept(accepted);
    }
    std::uint16_t port() const { return acceptor.local_endpoint().port(); }
    tcp::acceptor acceptor;
    tcp::socket client;
    tcp::socket accepted;
};

TEST(TcpNodelay, TurnsNagleOffOnlyOnConnectionsToTheGivenPort) {
    net::io_context io;
    connected_pair broker(io);
    connected_pair other(io);
    ASSERT_FALSE(nagle_off(broker.client));

    EXPECT_EQ(disable_nagle_towards({broker.port()}), 1);

    EXPECT_TRUE(nagle_off(broker.client));
    EXPECT_FALSE(nagle_off(broker.accepted));  // its peer is the client's ephemeral port
    EXPECT_FALSE(nagle_off(other.client));
    EXPECT_FALSE(nagle_off(other.accepted));
}

TEST(TcpNodelay, FindsNothingWhenNoConnectionGoesToThePort) {
    net::io_context io;
    connected_pair other(io);
    EXPECT_EQ(disable_nagle_towards({}), 0);
    EXPECT_FALSE(nagle_off(other.client));
}

}  // namespace
}  // namespace gw::api
