#pragma once
// http.trusted_proxies: the reverse proxies in front of the gateway (nginx, Caddy), by address or
// network. A connection from one of them speaks for many clients: the client a request comes from
// is taken from its X-Forwarded-For header, and the proxy is not held to one address's share of the
// connections. From any other peer, X-Forwarded-For is ignored: anyone can write the header.
//
//   auto proxies = trusted_proxies::parse({"127.0.0.1", "10.0.0.0/8"});   // or the error, naming the entry
//   proxies->client_address(peer, request["X-Forwarded-For"]);            // "192.0.2.7"
//
// Pure; immutable after parse, so it may be read from any thread.

#include <string>
#include <string_view>
#include <vector>

#include <boost/asio/ip/address.hpp>
#include <boost/asio/ip/network_v4.hpp>
#include <boost/asio/ip/network_v6.hpp>
#include <boost/system/result.hpp>

namespace gw {

class trusted_proxies {
  public:
    // Entries: an address ("10.0.0.5", "::1") or a network ("10.0.0.0/8", "fd00::/8"). The error
    // names the first entry that is neither.
    static boost::system::result<trusted_proxies, std::string> parse(const std::vector<std::string>& entries);

    bool empty() const { return v4_.empty() && v6_.empty(); }
    bool contains(const boost::asio::ip::address& address) const;

    // The client a request comes from: the peer itself, unless the peer is a trusted proxy; then the
    // rightmost address of X-Forwarded-For that is not a trusted proxy (each proxy appends the
    // address it saw, so the right end is the one a trusted proxy wrote). A header that is missing
    // or holds something else than addresses there gives the last address read, or the peer's.
    std::string client_address(const boost::asio::ip::address& peer, std::string_view forwarded_for) const;

  private:
    std::vector<boost::asio::ip::network_v4> v4_;
    std::vector<boost::asio::ip::network_v6> v6_;
};

}  // namespace gw
