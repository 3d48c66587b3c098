#pragma once
// What a shared port shows of itself (GET /api/v1/controllers/{id}, the dashboard, /metrics): where it
// is, its role, and who is connected with what they sent.

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace gw::devices::share {

struct client_status {
    std::string name;  // "tcp 127.0.0.1:50412" or "pty"
    std::chrono::system_clock::time_point since{};
    std::uint64_t commands = 0;       // lines sent to the controller
    std::uint64_t refused = 0;        // lines answered by the gateway with an error of its own
    std::uint64_t dropped_bytes = 0;  // replies dropped because the client did not read them
    std::uint64_t late = 0;  // answers that came after the command timeout, not sent (the client gave up)
};

struct port_status {
    std::string controller;
    std::string pty;  // the link path, "" = none
    std::string tcp;  // "HOST:PORT" as bound, "" = none
    std::string role;
    bool lease = false;
    bool holds_lease = false;  // the port holds the controller's lease now
    std::vector<client_status> clients;
    std::string report_pty;  // the shared report stream, "" = none
    std::string report_tcp;
    std::vector<client_status> report_readers;
    std::uint64_t commands = 0;  // every client's, since start
    std::uint64_t refused = 0;
    std::uint64_t clients_refused = 0;  // TCP connections closed at once: max_clients were connected
};

}  // namespace gw::devices::share
