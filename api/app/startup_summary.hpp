#pragma once
// The one line the gateway logs once it serves: where (the URL), where its jobs are (the storage
// directory) and which controllers it opens, so a person starting it knows at once what it does.

#include <map>
#include <string>
#include <vector>

#include <boost/asio/ip/tcp.hpp>

#include "devices/serial/controller_snapshot.hpp"

namespace gw {

// "serving http://127.0.0.1:8080/ (storage /var/lib/asi-gateway; controllers: sim1 on /tmp/x/sim1/port
// shared at pty /tmp/x/sim1/share, ...; MQTT to mqtt://broker:1883)". `brokers` empty: MQTT is off.
// `shared_at`: controller id -> where its shared port is ("pty /run/x, tcp 127.0.0.1:7001").
std::string startup_summary(const std::string& url, const std::string& storage,
                            const std::vector<devices::controller_snapshot>& controllers,
                            const std::vector<std::string>& brokers,
                            const std::map<std::string, std::string>& shared_at = {});

// "http://127.0.0.1:8080/", "http://[::1]:8080/", "https://..." with `tls`; an unspecified address
// (0.0.0.0, ::) is shown as such, since it serves on every interface.
std::string http_url(const boost::asio::ip::tcp::endpoint& http, bool tls = false);

}  // namespace gw
