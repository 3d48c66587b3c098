#include "api/mqtt/connect_failure.hpp"

#include <string>

#include <gtest/gtest.h>

namespace gw::api {
namespace {

struct failure_case {
    const char* name;
    connect_failure failure;
    const char* expected;  // a part of the explanation
};

TEST(ConnectFailure, ExplainsWhatPahoReports) {
    const failure_case cases[] = {
        {"unknown CA",
         {-1, 0, "error:0A000086:SSL routines::certificate verify failed", ""},
         "unknown CA: check tls.ca_file"},
        {"wrong host name",
         {-1, 0, "certificate verify failed (SSL routines): hostname mismatch", ""},
         "wrong host name"},
        {"client certificate refused",
         {-1, 0, "error:0A00045C:SSL routines::tlsv13 alert certificate required", ""},
         "refused this gateway's client certificate"},
        {"unknown ca alert",
         {-1, 0, "error:0A000418:SSL routines::tlsv1 alert unknown ca", ""},
         "bad certificate"},
        {"plain port",
         {-1, 0, "error:0A00010B:SSL routines::wrong version number", ""},
         "does not speak TLS"},
        {"v3 not authorised", {5, 0, "", ""}, "not authorised"},
        {"v3 bad password", {4, 0, "", ""}, "bad user name or password"},
        {"v5 not authorised", {-1, 0x87, "", ""}, "not authorised"},
        {"v5 bad password", {-1, 0x86, "", ""}, "bad user name or password"},
        {"v5 reason as Paho C++ reports it", {0x87, 0, "", ""}, "not authorised"},
        {"connection refused", {-1, 0, "", "Connection refused"}, "connection refused: nothing listens"},
        {"unreachable", {-1, 0, "", "No route to host"}, "cannot reach the broker: No route to host"},
        {"nothing known", {-1, 0, "", ""}, "failed before MQTT"},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.name);
        const auto text = explain_connect_failure(c.failure);
        EXPECT_NE(text.find(c.expected), std::string::npos) << text;
        EXPECT_NE(text.find("[rc " + std::to_string(c.failure.return_code)), std::string::npos) << text;
    }
    // The TLS text itself is kept, for what the mapping does not know.
    EXPECT_NE(explain_connect_failure({-1, 0, "error:1234:odd failure", ""}).find("odd failure"),
              std::string::npos);
}

TEST(ConnectFailure, ParsesBrokerAddresses) {
    auto a = parse_broker_address("mqtt://127.0.0.1:1884");
    EXPECT_EQ(a.host, "127.0.0.1");
    EXPECT_EQ(a.port, "1884");
    a = parse_broker_address("mqtts://broker.lab");
    EXPECT_EQ(a.host, "broker.lab");
    EXPECT_EQ(a.port, "8883");
    a = parse_broker_address("tcp://broker.lab");
    EXPECT_EQ(a.port, "1883");
    a = parse_broker_address("ssl://[::1]:8884");
    EXPECT_EQ(a.host, "::1");
    EXPECT_EQ(a.port, "8884");
}

}  // namespace
}  // namespace gw::api
