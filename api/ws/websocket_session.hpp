#pragma once
// WebSocket sessions (/api/v1/ws). The HTTP session hands over an authenticated upgrade request
// through start_websocket_session(); from then on the websocket_session owns the connection.
//
// One websocket_session per connection, on the connection's strand (the stream's executor: the
// listener accepts every socket on its own strand). It is an event hub subscriber (event_sink): the
// hub delivers a batch, the session writes it one frame at a time (one write in flight) and asks
// for more when the batch is written, so events wait in the hub's bounded per-subscriber queue,
// never here. Answers to the client's own messages (acks, results, errors, pongs) wait in a small
// queue; when it is full, or too many commands run at once, the session stops reading the client
// until it drains (TCP backpressure), so a client cannot make it buffer without bound.
// A client that stays too slow is closed with 1008 (policy violation) "too slow: ...": by the hub
// (queue overflow, stall) or by the session (one frame not written within write_timeout). The hub's
// stop() closes every session with 1001 (going away). Messages over max_message_bytes close the
// connection with 1009 (Beast); idle connections are pinged and closed after idle_timeout.
// Batched (?batch_ms=N, api/websocket_protocol.hpp): each hub batch is one "batch" message, and the
// session asks for the next no sooner than N ms after the previous one arrived; meanwhile events wait
// in the hub, whose queue for a batched session is larger.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "api/calls/calls.hpp"
#include "api/calls/operation_requests.hpp"
#include "api/common/api_context.hpp"
#include "api/common/auth.hpp"
#include "api/common/connection_permit.hpp"
#include "api/common/http_stream.hpp"
#include "api/common/net.hpp"
#include "gateway/events/event.hpp"
#include "gateway/events/event_sink.hpp"

namespace gw::api {

struct job_message;
struct api_outcome;

// Takes over the connection: accepts the upgrade `request` (already read, already authenticated as
// `who`) and runs the session until it closes. The session keeps the connection's `permit` (its slot
// in http.limits.max_connections) until it ends. `batch_window`: the client's batch_ms.
void start_websocket_session(http_stream&& stream, http::request<http::string_body>&& request,
                             std::shared_ptr<api_context> context, auth_identity who,
                             std::shared_ptr<connection_permit> permit = nullptr,
                             std::optional<std::chrono::milliseconds> batch_window = std::nullopt);

struct websocket_limits {
    std::size_t max_message_bytes = std::size_t{64} * 1024;  // client messages (http.limits)
    std::chrono::milliseconds idle_timeout{30'000};          // ping after half of it, close after it
    std::chrono::milliseconds write_timeout{30'000};         // one frame stuck longer: "too slow"
    std::chrono::milliseconds close_timeout{5'000};          // close handshake; then the socket is closed
    std::size_t answer_queue_limit = 32;                     // queued answers before reading pauses
    // Running commands; more wait in order (up to max_commands_waiting, then queue_full). Reading never
    // pauses for commands, and a HALT never waits: it runs at once, ahead of those waiting.
    std::size_t max_commands_in_flight = 16;
    std::size_t max_commands_waiting = 64;
    std::size_t max_subscriptions = 64;  // filters per connection
};

// From http.limits: max_websocket_message_bytes; read_timeout is the write timeout, twice it the
// idle timeout (a ping after one read_timeout of silence).
websocket_limits websocket_limits_from(const http_limits& limits);

class websocket_session final : public gw::event_sink,
                                public std::enable_shared_from_this<websocket_session> {
  public:
    websocket_session(http_stream&& stream, std::shared_ptr<api_context> context, auth_identity who,
                      websocket_limits limits, std::shared_ptr<connection_permit> permit = nullptr,
                      std::optional<std::chrono::milliseconds> batch_window = std::nullopt);
    ~websocket_session() override;

    // Accepts the upgrade and starts reading. Call once.
    void run(http::request<http::string_body> request);
    // Closes with 1001 (going away) and `reason`. Any thread.
    void stop(std::string reason);

    const std::string& connection() const { return connection_; }

    // event_sink: called on the hub's strand; both post to the session's strand.
    void deliver(std::vector<std::shared_ptr<const event>> batch) override;
    void close(std::string reason) override;

  private:
    enum class phase : std::uint8_t { handshake, open, closing, closed };
    struct frame {
        std::shared_ptr<const std::string> text;
        bool ends_batch = false;  // the last frame of a hub batch: request_more after writing it
        bool answer = false;      // counts against answer_queue_limit
    };

    void on_accept(beast::error_code ec);
    void do_read();
    void on_read(beast::error_code ec, std::size_t bytes);
    void handle_message(std::string_view text);
    void answer(std::string text);
    void answer_error(const nlohmann::json& id, problem p);
    // A command or job message: dispatched as a call (api/calls.hpp), answered with its outcome.
    void run_call(const nlohmann::json& id, std::optional<std::string> lease, call c);
    void start_call(const nlohmann::json& id, std::optional<std::string> lease, call c);
    void on_call_done(const nlohmann::json& id, api_outcome outcome);
    void on_deliver(const std::vector<std::shared_ptr<const event>>& batch);
    void do_write();
    void on_write(beast::error_code ec, std::size_t bytes);
    // A hub batch is written: ask for the next one now, or when the batch window allows.
    void request_next_batch();
    void begin_close(websocket::close_code code, std::string reason);
    void do_close();
    void on_close(beast::error_code ec);
    void schedule_watchdog();
    void on_watchdog(beast::error_code ec);
    bool reading_blocked() const;
    void maybe_resume_reading();
    void finish(std::string_view why);
    void fail(beast::error_code ec, std::string_view what);

    websocket::stream<http_stream> ws_;
    std::shared_ptr<api_context> ctx_;
    auth_identity who_;
    websocket_limits limits_;
    std::string connection_;      // "ws-<n>": log context and request-id prefix
    std::string client_address_;  // the peer's address, for the audit trail
    http::request<http::string_body> upgrade_;
    std::uint64_t subscriber_ = 0;
    bool hub_closed_ = false;  // the hub dropped us; no remove_subscriber needed
    phase phase_ = phase::handshake;
    beast::flat_buffer in_;
    std::deque<frame> out_;
    std::size_t answers_queued_ = 0;
    std::size_t commands_in_flight_ = 0;
    struct waiting_call {
        nlohmann::json id;
        std::optional<std::string> lease;
        call c;
    };
    std::deque<waiting_call> commands_waiting_;  // over max_commands_in_flight, in arrival order
    std::set<std::string> filters_;
    bool reading_ = false;
    bool writing_ = false;
    bool close_started_ = false;
    bool counted_ = false;  // in gw_websocket_clients
    websocket::close_code close_code_ = websocket::close_code::normal;
    std::string close_reason_;
    std::string end_reason_ = "client";  // for gw_websocket_disconnects_total
    std::chrono::steady_clock::time_point write_started_;
    std::chrono::steady_clock::time_point close_deadline_;
    net::steady_timer watchdog_;
    std::shared_ptr<connection_permit> permit_;              // released with the session
    std::optional<std::chrono::milliseconds> batch_window_;  // batched connection (batch_ms)
    std::chrono::steady_clock::time_point batch_arrived_;    // when the last hub batch came
    net::steady_timer batch_timer_;
};

}  // namespace gw::api
