#include "api/mqtt/mqtt_commands.hpp"

#include <algorithm>
#include <chrono>
#include <utility>
#include <variant>

#include <boost/asio/bind_executor.hpp>
#include <spdlog/logger.h>

#include "api/calls/job_requests.hpp"
#include "api/mqtt/mqtt_request.hpp"
#include "api/ws/websocket_protocol.hpp"
#include "gateway/common/metrics.hpp"
#include "gateway/common/timestamp.hpp"

namespace gw::api {

namespace net = boost::asio;
using nlohmann::json;

mqtt_commands::mqtt_commands(std::shared_ptr<api_context> ctx, mqtt_topics topics, int response_qos, strand s,
                             publish_fn publish, std::size_t max_payload_bytes, authentication auth,
                             std::size_t max_in_flight)
    : ctx_(std::move(ctx)),
      topics_(std::move(topics)),
      response_qos_(response_qos),
      strand_(std::move(s)),
      publish_(std::move(publish)),
      max_payload_bytes_(max_payload_bytes),
      auth_(std::move(auth)),
      replays_(auth_.signature_window, max_remembered_signatures),
      max_in_flight_(max_in_flight) {}

mqtt_commands::reply_target mqtt_commands::reply_for(const mqtt_message_in& in,
                                                     const std::optional<std::string>& reply_to) const {
    // The MQTT 5 response topic wins; one the gateway may not write to is ignored.
    if (!in.response_topic.empty() && topics_.is_allowed_reply_topic(in.response_topic))
        return {in.response_topic, in.correlation_data};
    if (reply_to) return {*reply_to, in.correlation_data};
    return {};
}

void mqtt_commands::count(std::string_view outcome) {
    if (ctx_->metrics)
        ctx_->metrics->increment("gw_mqtt_commands_total", {{"outcome", std::string(outcome)}});
}

void mqtt_commands::answer(const reply_target& to, std::string payload, std::string_view outcome) {
    count(outcome);
    if (to.topic.empty()) return;
    mqtt_message_out m;
    m.topic = to.topic;
    m.payload = std::move(payload);
    m.qos = response_qos_;
    m.retained = false;
    m.correlation_data = to.correlation_data;
    publish_(std::move(m));
}

void mqtt_commands::answer_error(const reply_target& to, const json& id, problem p, std::string_view topic) {
    if (p.instance.empty()) p.instance = std::string(topic);
    if (ctx_->log) ctx_->log->debug("mqtt {}: refused: {}", topic, p.detail);
    answer(to, call_error_message(id, p), p.status >= 500 ? "failed" : "refused");
}

void mqtt_commands::handle(const mqtt_message_in& in) {
    auto target = topics_.parse_command_topic(in.topic);
    if (!target) return;  // not ours (a retained leftover on a filter we share)
    // Nothing is answered before the sender is known: an answer would make the gateway publish, under
    // its own broker identity, wherever an anonymous message asked.
    if (in.payload.size() > max_payload_bytes_)
        return drop(in.topic, "unreadable",
                    "a payload of " + std::to_string(in.payload.size()) +
                        " bytes, over mqtt.commands.max_payload_bytes (" +
                        std::to_string(max_payload_bytes_) + ")");
    std::optional<auth_identity> who;
    std::optional<mqtt_envelope> envelope;
    if (looks_signed(in.payload)) {
        auto verified = verify_signed(in);
        if (!verified) return;
        auto opened = open_mqtt_envelope(verified->second, max_payload_bytes_);
        if (!opened) return drop(in.topic, "unreadable", "the signed body: " + opened.error());
        if (!opened->token.empty()) {
            // Known sender, so answered: a token next to a signature is a token published for nothing.
            auto p = make_problem(make_error(operation_error_kind::invalid_value,
                                             "a signed command carries no \"token\" (it is readable on the "
                                             "topic): leave it out",
                                             "token"));
            return answer_error(reply_for(in, std::nullopt), json(), std::move(p), in.topic);
        }
        who = std::move(verified->first);
        envelope = std::move(*opened);
    } else {
        if (!auth_.accept_bearer_tokens)
            return drop(in.topic, "unauthenticated",
                        "not signed (bearer tokens are not taken over MQTT unless "
                        "mqtt.commands.accept_bearer_tokens)");
        auto opened = open_mqtt_envelope(in.payload, max_payload_bytes_);
        if (!opened) return drop(in.topic, "unreadable", opened.error());
        if (opened->token.empty()) return drop(in.topic, "unauthenticated", "no \"token\"");
        problem auth_error;
        who = authenticate_token(ctx_->auth, opened->token, auth_error);
        if (!who) return drop(in.topic, "unauthenticated", auth_error.detail);
        envelope = std::move(*opened);
    }
    if (in.retained) {
        // A retained command would run again at every reconnect: never run one.
        auto p =
            make_problem(make_error(operation_error_kind::invalid_value,
                                    "retained command messages are not run (publish with retain=false)"));
        return answer_error(reply_for(in, std::nullopt), json(), std::move(p), in.topic);
    }
    const auto generated = "mqtt-" + std::to_string(next_id_++);
    auto parsed = parse_mqtt_request(topics_, *target, in.topic, std::move(*envelope), generated);
    if (!parsed) {
        auto e = std::move(parsed.error());
        return answer_error(reply_for(in, e.reply_to), e.id, std::move(e.error), in.topic);
    }
    auto& request = *parsed;
    const auto to = reply_for(in, request.reply_to);
    // The bound on commands running at once never holds back a HALT.
    const auto* command = std::get_if<command_message>(&request.message);
    const bool halt = std::holds_alternative<halt_all_message>(request.message) ||
                      (command && command->operation == "halt");
    if (in_flight_ >= max_in_flight_ && !halt) {
        auto p = make_problem(make_error(
            operation_error_kind::queue_full,
            "too many MQTT commands running (" + std::to_string(max_in_flight_) + "); try again later"));
        return answer_error(to, request.id, std::move(p), in.topic);
    }
    run(request, *who, to);
}

std::optional<std::pair<auth_identity, std::string>> mqtt_commands::verify_signed(const mqtt_message_in& in) {
    auto signed_command = read_signed_command(in.payload);
    if (!signed_command) {
        drop(in.topic, "unreadable", signed_command.error());
        return std::nullopt;
    }
    auto& c = *signed_command;
    const auto key = std::find_if(auth_.signing_keys.begin(), auth_.signing_keys.end(),
                                  [&](const mqtt_signing_key& k) { return k.name == c.key; });
    if (key == auth_.signing_keys.end()) {
        drop(in.topic, "unauthenticated", "unknown signing key \"" + c.key + "\"");
        return std::nullopt;
    }
    if (!signature_matches(key->key, signing_text(in.topic, c.ts_ms, c.nonce, c.body), c.sig)) {
        drop(in.topic, "unauthenticated", "the signature of key \"" + c.key + "\" does not match");
        return std::nullopt;
    }
    const auto now_ms = epoch_ms(std::chrono::system_clock::now());
    switch (replays_.admit(c.key, c.nonce, c.ts_ms, now_ms)) {
        case signature_replay_guard::verdict::fresh:
            break;
        case signature_replay_guard::verdict::stale:
            drop(in.topic, "unauthenticated",
                 "ts " + std::to_string(c.ts_ms) + " is " + std::to_string((now_ms - c.ts_ms) / 1000) +
                     " s from the gateway's clock, outside mqtt.commands.signature_window_s (clocks in "
                     "sync?)");
            return std::nullopt;
        case signature_replay_guard::verdict::replayed:
            drop(in.topic, "replayed", "key \"" + c.key + "\" used nonce " + c.nonce + " before");
            return std::nullopt;
        case signature_replay_guard::verdict::full:
            drop(in.topic, "replayed", "too many signed commands within the window to remember");
            return std::nullopt;
    }
    return std::make_pair(auth_identity{key->name, key->role}, std::move(c.body));
}

void mqtt_commands::drop(std::string_view topic, std::string_view outcome, const std::string& why) {
    count(outcome);
    // Info, at most once a second: a flood of anonymous messages must not flood the log too.
    const auto now = std::chrono::steady_clock::now();
    if (ctx_->log && now - last_drop_logged_ >= std::chrono::seconds(1)) {
        last_drop_logged_ = now;
        ctx_->log->info("mqtt {}: dropped unanswered ({}): {} ({} dropped so far)", topic, outcome, why,
                        ++dropped_);
        return;
    }
    ++dropped_;
}

void mqtt_commands::run(mqtt_request& request, const auth_identity& who, const reply_target& to) {
    const auto request_id = mqtt_request_id(request.id);
    const std::string topic = topics_.command(request.target);
    // The same dispatch as REST and WebSocket: role, lease, validation, request id.
    std::optional<call> c;
    json id;
    std::optional<std::string> lease;
    if (auto* command = std::get_if<command_message>(&request.message)) {
        id = command->id;
        lease = command->lease;
        c = to_call(std::move(*command));
    } else if (auto* job = std::get_if<job_message>(&request.message)) {
        id = job->id;
        lease = job->lease;
        c = to_call(std::move(*job));
    } else if (auto* gcode = std::get_if<gcode_message>(&request.message)) {
        id = gcode->id;
        c = to_call(std::move(*gcode));
    } else if (auto* halt = std::get_if<halt_all_message>(&request.message)) {
        id = halt->id;
        c = halt_all_call{};
    } else {
        return;  // parse_mqtt_request only builds commands, jobs, G-code checks and HALT ALL
    }
    ++in_flight_;
    dispatch_call(*ctx_, caller{who.name, who.role, request_id, std::move(lease), "mqtt", {}}, std::move(*c),
                  net::bind_executor(strand_, [self = shared_from_this(), to, id, topic](api_outcome out) {
                      --self->in_flight_;
                      if (out.error) return self->answer_error(to, id, std::move(*out.error), topic);
                      self->answer(to, call_result_message(id, out.body, out.replayed), "ok");
                  }));
}

}  // namespace gw::api
