// X-Forwarded-For as a trusted proxy passes it on (gateway/config/trusted_proxies.hpp), on arbitrary
// bytes. Input: the peer's address, a newline, then the header's value. Checks: the client named is
// always an address that parses; from a peer that is not a trusted proxy it is that peer, whatever
// the header says; and it is never a trusted proxy unless every address read was one.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include <boost/asio/ip/address.hpp>

#include "gateway/config/trusted_proxies.hpp"

namespace {

void check(bool condition, int line = __builtin_LINE()) {
    if (condition) return;
    std::fprintf(stderr, "fuzz_forwarded_for.cpp:%d: check failed\n", line);
    std::abort();
}

const gw::trusted_proxies& proxies() {
    static const auto p = *gw::trusted_proxies::parse({"127.0.0.1", "10.0.0.0/8", "fd00::/8"});
    return p;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view input(reinterpret_cast<const char*>(data), size);
    const auto newline = input.find('\n');
    if (newline == std::string_view::npos) return 0;
    boost::system::error_code ec;
    const auto peer = boost::asio::ip::make_address(std::string(input.substr(0, newline)), ec);
    if (ec) return 0;
    const auto forwarded = input.substr(newline + 1);

    const auto client = proxies().client_address(peer, forwarded);
    const auto parsed = boost::asio::ip::make_address(client, ec);
    check(!ec);
    if (!proxies().contains(peer)) check(parsed == peer || (peer.is_v6() && peer.to_v6().is_v4_mapped()));
    // A trusted proxy is named only when nothing untrusted was found: then no untrusted address
    // stands right of it in the header.
    if (proxies().contains(parsed)) check(proxies().contains(peer));
    return 0;
}
