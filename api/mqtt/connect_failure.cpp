#include "api/mqtt/connect_failure.hpp"

namespace gw::api {

namespace {

bool has(std::string_view text, std::string_view part) {
    return text.find(part) != std::string_view::npos;
}

std::string explain_tls(std::string_view e) {
    if (has(e, "hostname mismatch") || has(e, "Hostname mismatch"))
        return "TLS handshake failed: the broker's certificate does not name the host of the broker URL "
               "(wrong host name: use a name its certificate has)";
    if (has(e, "certificate verify failed"))
        return "TLS handshake failed: the broker's certificate is not trusted (unknown CA: check "
               "tls.ca_file)";
    if (has(e, "hostname") || has(e, "host name"))
        return "TLS handshake failed: the broker's certificate does not name the host of the broker URL "
               "(wrong "
               "host name)";
    if (has(e, "unknown ca") || has(e, "bad certificate") || has(e, "certificate required") ||
        has(e, "handshake failure") || has(e, "certificate unknown"))
        return "TLS handshake failed: the broker refused this gateway's client certificate (bad certificate: "
               "check tls.cert_file and tls.key_file against the broker's CA)";
    if (has(e, "reset by peer") || has(e, "stream truncated") || has(e, "End of file"))
        return "TLS handshake failed: the broker closed the connection during the handshake (a plain MQTT "
               "port for an mqtts:// URL?)";
    if (has(e, "wrong version number") || has(e, "packet length too long") || has(e, "record layer failure"))
        return "TLS handshake failed: the broker's port does not speak TLS (an mqtts:// URL for a plain MQTT "
               "listener?)";
    if (has(e, "key values mismatch") || has(e, "PEM") || has(e, "no such file") || has(e, "system lib"))
        return "TLS setup failed: a TLS file cannot be used (check tls.ca_file, tls.cert_file, tls.key_file "
               "with --check-config)";
    return "TLS handshake failed";
}

std::string connack_v3(int rc) {
    switch (rc) {
        case 1:
            return "refused by the broker: unacceptable protocol version (set mqtt.protocol to the broker's)";
        case 2:
            return "refused by the broker: client identifier rejected";
        case 3:
            return "refused by the broker: server unavailable";
        case 4:
            return "not authorised: bad user name or password (mqtt.username, mqtt.password)";
        case 5:
            return "not authorised: the broker refuses this client (check mqtt.username and the broker's "
                   "ACL)";
        default:
            return {};
    }
}

std::string reason_v5(int reason) {
    switch (reason) {
        case 0x84:
            return "refused by the broker: unsupported protocol version (set mqtt.protocol to the broker's)";
        case 0x85:
            return "refused by the broker: client identifier not valid";
        case 0x86:
            return "not authorised: bad user name or password (mqtt.username, mqtt.password)";
        case 0x87:
            return "not authorised: the broker refuses this client (check mqtt.username and the broker's "
                   "ACL)";
        case 0x88:
        case 0x89:
            return "refused by the broker: server unavailable or busy";
        case 0x8A:
            return "refused by the broker: this client is banned";
        case 0x8C:
            return "refused by the broker: bad authentication method";
        case 0x9C:
        case 0x9D:
            return "refused by the broker: use another server";
        default:
            return {};
    }
}

}  // namespace

std::string explain_connect_failure(const connect_failure& f) {
    std::string why;
    if (!f.tls_error.empty()) {
        why = explain_tls(f.tls_error) + " (" + f.tls_error + ")";
    } else if (auto v5 = reason_v5(f.reason_code); !v5.empty()) {
        why = v5;
    } else if (auto v5_rc = reason_v5(f.return_code); !v5_rc.empty()) {
        why = v5_rc;  // Paho C++ hands an MQTT 5 CONNACK reason over as the return code
    } else if (auto v3 = connack_v3(f.return_code); !v3.empty()) {
        why = v3;
    } else if (!f.tcp_error.empty()) {
        if (has(f.tcp_error, "refused"))
            why =
                "connection refused: nothing listens on the broker's host and port (is the broker running? "
                "the "
                "right port?)";
        else
            why = "cannot reach the broker: " + f.tcp_error;
    } else {
        why =
            "the connection failed before MQTT (the broker closed it, or a TLS handshake failed without a "
            "reason)";
    }
    why += " [rc " + std::to_string(f.return_code);
    if (f.reason_code != 0) why += ", reason " + std::to_string(f.reason_code);
    return why + "]";
}

broker_address parse_broker_address(std::string_view uri) {
    broker_address a;
    std::string default_port = "1883";
    if (const auto scheme = uri.find("://"); scheme != std::string_view::npos) {
        const auto s = uri.substr(0, scheme);
        if (s == "mqtts" || s == "ssl" || s == "wss") default_port = "8883";
        uri.remove_prefix(scheme + 3);
    }
    if (const auto slash = uri.find('/'); slash != std::string_view::npos) uri = uri.substr(0, slash);
    if (uri.starts_with('[')) {  // [::1]:1883
        const auto close = uri.find(']');
        if (close == std::string_view::npos) return {};
        a.host = std::string(uri.substr(1, close - 1));
        const auto rest = uri.substr(close + 1);
        a.port = rest.starts_with(':') ? std::string(rest.substr(1)) : default_port;
        return a;
    }
    const auto colon = uri.rfind(':');
    a.host = std::string(uri.substr(0, colon));
    a.port = colon == std::string_view::npos ? default_port : std::string(uri.substr(colon + 1));
    if (a.port.empty()) a.port = default_port;
    return a;
}

}  // namespace gw::api
