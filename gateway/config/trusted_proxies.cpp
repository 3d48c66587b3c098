#include "gateway/config/trusted_proxies.hpp"

#include <boost/asio/ip/address_v4.hpp>

#include "devices/ms2000/ascii.hpp"

namespace gw {

namespace ip = boost::asio::ip;

namespace {

// An IPv4 peer of a dual-stack listener arrives as ::ffff:a.b.c.d.
ip::address unmapped(const ip::address& a) {
    if (a.is_v6() && a.to_v6().is_v4_mapped()) return ip::make_address_v4(ip::v4_mapped, a.to_v6());
    return a;
}

}  // namespace

boost::system::result<trusted_proxies, std::string> trusted_proxies::parse(
    const std::vector<std::string>& entries) {
    trusted_proxies out;
    for (const auto& entry : entries) {
        boost::system::error_code ec;
        const bool network = entry.find('/') != std::string::npos;
        if (entry.find(':') != std::string::npos) {
            auto net = network ? ip::make_network_v6(entry, ec)
                               : ip::network_v6(ip::make_address_v6(entry, ec), 128);
            if (!ec) out.v6_.push_back(net);
        } else {
            auto net =
                network ? ip::make_network_v4(entry, ec) : ip::network_v4(ip::make_address_v4(entry, ec), 32);
            if (!ec) out.v4_.push_back(net);
        }
        if (ec)
            return std::string("\"" + entry +
                               "\" must be an address (10.0.0.5, ::1) or a network (10.0.0.0/8, fd00::/8)");
    }
    return out;
}

bool trusted_proxies::contains(const ip::address& address) const {
    const auto a = unmapped(address);
    if (a.is_v4()) {
        for (const auto& n : v4_)
            if (ip::network_v4(a.to_v4(), 32).is_subnet_of(n) || n.address() == a.to_v4()) return true;
        return false;
    }
    for (const auto& n : v6_)
        if (ip::network_v6(a.to_v6(), 128).is_subnet_of(n) || n.address() == a.to_v6()) return true;
    return false;
}

std::string trusted_proxies::client_address(const ip::address& peer, std::string_view forwarded_for) const {
    auto client = unmapped(peer);
    if (!contains(client)) return client.to_string();
    // From the right: each hop a trusted proxy, until the first that is not.
    while (!forwarded_for.empty()) {
        const auto comma = forwarded_for.rfind(',');
        const auto item = devices::ms2000::trim_blanks(
            comma == std::string_view::npos ? forwarded_for : forwarded_for.substr(comma + 1));
        forwarded_for = comma == std::string_view::npos ? std::string_view{} : forwarded_for.substr(0, comma);
        boost::system::error_code ec;
        const auto hop = ip::make_address(std::string(item), ec);
        if (ec) break;  // not an address: trust nothing further left
        client = unmapped(hop);
        if (!contains(client)) break;
    }
    return client.to_string();
}

}  // namespace gw
