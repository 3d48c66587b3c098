#pragma once
// Commands received on the MQTT command topics, decoded into calls and run by the same dispatch as
// REST and WebSocket (api/calls.hpp): the same validation, roles, leases and result shapes. Each request
// is signed with a key of mqtt.commands.signing_keys (api/mqtt/mqtt_signature.hpp), whose role it gets;
// a bearer token of auth.tokens in the payload ("token") is taken only with
// mqtt.commands.accept_bearer_tokens (TLS brokers only).
//
// Answers (the WebSocket "result" / "error" messages) go to the MQTT 5 response topic with the
// request's correlation data, else to the payload's "reply_to". A request with neither is still run
// (fire and forget); a malformed one is answered with an error if it can be, never run, and never
// reaches a serial line. A payload over max_payload_bytes, one that is no JSON object, one whose
// signature does not hold (unknown key, wrong signature, ts outside the window, a nonce used before)
// or, without a signature, without a bearer token the gateway takes, is dropped unanswered (counted,
// logged at most once a second): an unauthenticated sender gets nothing published. At most max_in_flight
// commands run at once; more are refused with 503.
//
// Commands never run late (api/mqtt/command_deadline.hpp): one that arrives after its deadline is
// answered stale-command (408) and not run; one that changes something and carries no deadline (an
// unsigned command without MQTT 5 message expiry or "not_after") is refused (422, field not_after).
// A command is run and answered once: a second delivery of a (sender, id), or of a (sender, MQTT 5
// correlation data) when it has no id, within freshness.redelivery_window (a QoS 1 redelivery after a
// failover, a bridge's resend) is dropped unanswered and counted as "duplicate". A HALT is never
// refused: not for its age, nor for the bound, nor as a duplicate. On the bridge's strand only.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/strand.hpp>
#include <nlohmann/json.hpp>

#include "api/calls/calls.hpp"
#include "api/common/api_context.hpp"
#include "api/common/auth.hpp"
#include "api/common/problem.hpp"
#include "api/mqtt/mqtt_client.hpp"
#include "api/mqtt/mqtt_signature.hpp"
#include "api/mqtt/mqtt_topics.hpp"
#include "api/mqtt/replay_window.hpp"
#include "gateway/config/config.hpp"

namespace gw::api {

struct mqtt_request;

class mqtt_commands : public std::enable_shared_from_this<mqtt_commands> {
  public:
    using strand = boost::asio::strand<boost::asio::any_io_executor>;
    using publish_fn = std::function<void(mqtt_message_out)>;

    struct authentication {
        std::vector<mqtt_signing_key> signing_keys;
        std::chrono::milliseconds signature_window{30000};
        bool accept_bearer_tokens = false;
    };
    struct freshness {
        std::chrono::milliseconds max_age{10000};  // a signed command's deadline: ts + max_age
        std::chrono::milliseconds redelivery_window{600000};
    };
    // Signed commands remembered for replay checks at most (api/mqtt/mqtt_signature.hpp), and
    // command ids for redelivery checks.
    static constexpr std::size_t max_remembered_signatures = 100000;
    static constexpr std::size_t max_remembered_ids = 100000;

    mqtt_commands(std::shared_ptr<api_context> ctx, mqtt_topics topics, int response_qos, strand s,
                  publish_fn publish, std::size_t max_payload_bytes, authentication auth, freshness fresh,
                  std::size_t max_in_flight = 64);

    // A message on one of the command topics.
    void handle(const mqtt_message_in& in);

    std::size_t in_flight() const { return in_flight_; }

  private:
    struct reply_target {
        std::string topic;  // "" when nobody can be answered
        std::string correlation_data;
    };
    reply_target reply_for(const mqtt_message_in& in, const std::optional<std::string>& reply_to) const;
    // Why `request` may not run now (stale, no deadline), answered; false when it may.
    bool refused_as_late(const mqtt_request& request, const call& c, const mqtt_message_in& in,
                         std::optional<std::int64_t> signed_ts_ms, const reply_target& to);
    // Whether this delivery repeats one taken before (then dropped, counted).
    bool is_redelivery(const mqtt_request& request, const auth_identity& who, const mqtt_message_in& in,
                       const reply_target& to);
    void run(call c, const mqtt_request& request, const auth_identity& who, const reply_target& to);
    void answer(const reply_target& to, std::string payload, std::string_view outcome);
    void answer_error(const reply_target& to, const nlohmann::json& id, problem p, std::string_view topic);
    void count(std::string_view outcome);
    void drop(std::string_view topic, std::string_view outcome, const std::string& why);
    struct verified_command {
        auth_identity sender;
        std::string body;  // the command's JSON text
        std::int64_t ts_ms = 0;
    };
    // The sender of a signed payload, and the command; nullopt when dropped.
    std::optional<verified_command> verify_signed(const mqtt_message_in& in);

    std::shared_ptr<api_context> ctx_;
    mqtt_topics topics_;
    int response_qos_;
    strand strand_;
    publish_fn publish_;
    std::size_t max_payload_bytes_;
    authentication auth_;
    replay_window replays_;
    freshness freshness_;
    replay_window delivered_;  // (sender, id) of commands taken
    std::size_t max_in_flight_;
    std::size_t in_flight_ = 0;
    std::uint64_t dropped_ = 0;
    std::chrono::steady_clock::time_point last_drop_logged_{};
    std::uint64_t next_id_ = 1;
};

}  // namespace gw::api
