#pragma once
// Why a connection to the broker failed, in words a person can act on, from what Paho reports: the
// return code and MQTT 5 reason code of the failed connect and, when Paho says nothing more than
// "failure", what the gateway's own TCP connect and TLS handshake to the broker saw (broker_probe.hpp).
// Pure.
//   explain_connect_failure({-1, 0, "...:certificate verify failed:...", ""}) ->
//     "TLS handshake failed: the broker's certificate is not trusted (unknown CA: check tls.ca_file) ..."

#include <string>
#include <string_view>

namespace gw::api {

struct connect_failure {
    int return_code = 0;    // Paho's (MQTTASYNC_FAILURE -1, or an MQTT 3.1.1 CONNACK code 1..5)
    int reason_code = 0;    // MQTT 5 CONNACK reason (0x87 not authorised, ...), 0 if none
    std::string tls_error;  // the diagnostic handshake's error ("certificate verify failed ...: hostname
                            // mismatch"), or empty
    std::string tcp_error;  // a plain TCP connect's error ("Connection refused"), "" when it connected
                            // or was not tried
};

std::string explain_connect_failure(const connect_failure& f);

// "mqtts://broker.lab:8883" -> {"broker.lab", "8883"}; the default port of the scheme when none is
// given (1883, 8883 for mqtts:// and ssl://). Empty host for something it cannot read.
struct broker_address {
    std::string host;
    std::string port;
};
broker_address parse_broker_address(std::string_view uri);

}  // namespace gw::api
