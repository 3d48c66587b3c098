#pragma once
// Paho C 1.3 never sets TCP_NODELAY on its broker connection and offers no hook to its socket. With
// Nagle's algorithm on, a burst of small publishes (one report batch per controller per window) waits
// for the broker's delayed ACK: about 10 ms more median latency on loopback (bench/analysis.md). So
// once the client is connected, it finds its connection among the process's sockets by the broker's
// port and turns Nagle off there.

#include <cstdint>
#include <vector>

namespace gw::api {

// Sets TCP_NODELAY on every connected TCP socket of this process whose peer port is one of `ports`.
// Returns how many sockets it set. Another outgoing connection to such a port only gets lower latency.
int disable_nagle_towards(const std::vector<std::uint16_t>& ports);

}  // namespace gw::api
