#pragma once
// One slot of the connection_table (api/connection_table.hpp). The listener hands a permit to each
// accepted connection; it moves from the HTTP session into the WebSocket session at an upgrade, so a
// connection counts toward the limits for as long as its socket lives, whatever protocol it speaks.
// The HTTP session reports its phase through it (waiting for a header, idle between requests, reading
// a body, being served): the table sheds only connections that wait or read slowly. Destroying the
// permit frees the slot (any thread).

#include <cstdint>
#include <memory>

namespace gw::api {

class connection_table;

enum class connection_phase : std::uint8_t {
    awaiting_header,  // accepted, or a request's first bytes came: its header is not complete
    idle,             // keep-alive, between two requests
    reading_body,     // the header was accepted, its body is on its way
    serving,          // a request is being handled, or a WebSocket: never shed
    closing,          // answered and half-closed, reading what is left before the close: shed first
};

// What the table may do to a connection it tracks (the HTTP session).
class tracked_connection {
  public:
    virtual ~tracked_connection() = default;
    // Make room for a newcomer: close, unless its request is being handled by now.
    virtual void shed() = 0;
    // Close whatever the connection is doing (the server stops).
    virtual void close() = 0;
};

class connection_permit {
  public:
    connection_permit(std::shared_ptr<connection_table> table, std::uint64_t id, bool halt_only = false)
        : table_(std::move(table)), id_(id), halt_only_(halt_only) {}
    ~connection_permit();

    connection_permit(const connection_permit&) = delete;
    connection_permit& operator=(const connection_permit&) = delete;

    void track(std::weak_ptr<tracked_connection> c);
    void set_phase(connection_phase phase);
    // A slot of the HALT reserve: the connection may send a HALT and nothing else.
    bool halt_only() const { return halt_only_; }

  private:
    std::shared_ptr<connection_table> table_;  // shared: the listener may be gone before the last session
    std::uint64_t id_;
    bool halt_only_ = false;
};

}  // namespace gw::api
