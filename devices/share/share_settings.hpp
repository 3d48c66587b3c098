#pragma once
// Settings of one controller's shared port: where programs that speak to the controller itself (an
// acquisition program, a vendor console, a pyserial script) reach it through the gateway. A plain value;
// gateway/config/config.cpp fills it from `controllers[].share` (and for simulated controllers).

#include <cstddef>
#include <cstdint>
#include <string>
#include <sys/types.h>

namespace gw::devices::share {

// What a shared port's clients may send (ms2000::effect_of): viewer, only reads; operator, also moves
// and settings kept in the controller's memory; admin, everything, including flash writes, RESET, BAUD
// and verbs the protocol tables do not know. HALT is open to every role.
enum class share_role : std::uint8_t { viewer, operator_, admin };
const char* to_string(share_role role);

struct share_settings {
    std::string controller;     // the controller's id
    unsigned line_baud = 9600;  // the real link's rate: what an RFC 2217 client is told when it asks

    // A pseudo-terminal whose slave is linked at this path ("" = none). Mode and group of the slave
    // node, so that members of a group such as dialout may open it.
    std::string pty;
    mode_t pty_mode = 0660;
    std::string pty_group;  // "" = leave the group as the system made it

    // A TCP listener (raw bytes, RFC 2217 accepted); port 0 = none.
    std::string tcp_host = "127.0.0.1";
    std::uint16_t tcp_port = 0;

    // The report port (TTL_REPORT, SERIAL OUT), shared the same ways: its bytes unchanged to every
    // program that opens the pty or connects; what they send is ignored.
    std::string report_pty;
    std::string report_tcp_host = "127.0.0.1";
    std::uint16_t report_tcp_port = 0;

    share_role role = share_role::operator_;
    // While a client is connected, the shared port holds the controller's lease: REST, WebSocket and
    // MQTT callers get 409 leased, as with any lease.
    bool lease = false;

    std::size_t max_clients = 4;           // TCP connections at once; more are closed at once
    std::size_t max_queued_lines = 16;     // a client's lines waiting for their turn; reading pauses beyond
    std::size_t max_output_bytes = 65536;  // replies a client has not read yet; more are dropped

    bool enabled() const { return !pty.empty() || tcp_port != 0 || shares_reports(); }
    bool shares_reports() const { return !report_pty.empty() || report_tcp_port != 0; }
};

}  // namespace gw::devices::share
