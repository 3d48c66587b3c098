#include "api/app/startup_summary.hpp"

namespace gw {

std::string http_url(const boost::asio::ip::tcp::endpoint& http, bool tls) {
    const auto address = http.address();
    const auto host = address.is_v6() ? "[" + address.to_string() + "]" : address.to_string();
    return (tls ? "https://" : "http://") + host + ":" + std::to_string(http.port()) + "/";
}

std::string startup_summary(const std::string& url, const std::string& storage,
                            const std::vector<devices::controller_snapshot>& controllers,
                            const std::vector<std::string>& brokers,
                            const std::map<std::string, std::string>& shared_at) {
    std::string line = "serving " + url + " (storage " + storage + "; controllers: ";
    if (controllers.empty()) line += "none";
    for (std::size_t i = 0; i < controllers.size(); ++i) {
        if (i > 0) line += ", ";
        line += controllers[i].id + " on " + controllers[i].port;
        if (auto it = shared_at.find(controllers[i].id); it != shared_at.end())
            line += " shared at " + it->second;
    }
    if (!brokers.empty()) {
        line += "; MQTT to ";
        for (std::size_t i = 0; i < brokers.size(); ++i)
            line += (i > 0 ? ", " : "") + brokers[i];
    }
    return line + ")";
}

}  // namespace gw
