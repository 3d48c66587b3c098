#include "api/mqtt/mqtt_commands.hpp"

#include <algorithm>
#include <chrono>
#include <utility>
#include <variant>

#include <boost/asio/bind_executor.hpp>
#include <spdlog/logger.h>

#include "api/calls/job_requests.hpp"
#include "api/mqtt/command_deadline.hpp"
#include "api/mqtt/mqtt_request.hpp"
#include "api/ws/websocket_protocol.hpp"
#include "gateway/common/metrics.hpp"
#include "gateway/common/timestamp.hpp"

namespace gw::api {

namespace net = boost::asio;
using nlohmann::json;

namespace {

// The call a parsed request asks for (a copy: the request is still needed for its answer).
std::optional<call> call_of(const mqtt_request& r) {
    if (const auto* command = std::get_if<command_message>(&r.message))
        return to_call(command_message(*command));
    if (const auto* job = std::get_if<job_message>(&r.message)) return to_call(job_message(*job));
    if (const auto* gcode = std::get_if<gcode_message>(&r.message)) return to_call(gcode_message(*gcode));
    if (std::holds_alternative<halt_all_message>(r.message)) return halt_all_call{};
    return std::nullopt;  // parse_mqtt_request only builds commands, jobs, G-code checks and HALT ALL
}

std::optional<std::string> lease_of(const mqtt_request& r) {
    if (const auto* command = std::get_if<command_message>(&r.message)) return command->lease;
    if (const auto* job = std::get_if<job_message>(&r.message)) return job->lease;
    return std::nullopt;
}

}  // namespace

mqtt_commands::mqtt_commands(std::shared_ptr<api_context> ctx, mqtt_topics topics, int response_qos, strand s,
                             publish_fn publish, std::size_t max_payload_bytes, authentication auth,
                             freshness fresh, std::size_t max_in_flight)
    : ctx_(std::move(ctx)),
      topics_(std::move(topics)),
      response_qos_(response_qos),
      strand_(std::move(s)),
      publish_(std::move(publish)),
      max_payload_bytes_(max_payload_bytes),
      auth_(std::move(auth)),
      replays_(auth_.signature_window, max_remembered_signatures),
      freshness_(fresh),
      delivered_(fresh.redelivery_window, max_remembered_ids),
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
    std::optional<std::int64_t> signed_ts_ms;
    if (looks_signed(in.payload)) {
        auto verified = verify_signed(in);
        if (!verified) return;
        auto opened = open_mqtt_envelope(verified->body, max_payload_bytes_);
        if (!opened) return drop(in.topic, "unreadable", "the signed body: " + opened.error());
        if (!opened->token.empty()) {
            // Known sender, so answered: a token next to a signature is a token published for nothing.
            auto p = make_problem(make_error(operation_error_kind::invalid_value,
                                             "a signed command carries no \"token\" (it is readable on the "
                                             "topic): leave it out",
                                             "token"));
            return answer_error(reply_for(in, std::nullopt), json(), std::move(p), in.topic);
        }
        who = std::move(verified->sender);
        envelope = std::move(*opened);
        signed_ts_ms = verified->ts_ms;
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
    auto c = call_of(request);
    if (!c) return;
    // A HALT is never held back: not for its age, the bound, or as a repeat.
    if (is_emergency_stop(*c)) return run(std::move(*c), request, *who, to);
    if (refused_as_late(request, *c, in, signed_ts_ms, to)) return;
    if (in_flight_ >= max_in_flight_) {
        auto p = make_problem(make_error(
            operation_error_kind::queue_full,
            "too many MQTT commands running (" + std::to_string(max_in_flight_) + "); try again later"));
        return answer_error(to, request.id, std::move(p), in.topic);
    }
    // After the refusals above, so that a command refused for now can be sent again under its id.
    if (is_redelivery(request, *who, in, to)) return;
    run(std::move(*c), request, *who, to);
}

bool mqtt_commands::refused_as_late(const mqtt_request& request, const call& c, const mqtt_message_in& in,
                                    std::optional<std::int64_t> signed_ts_ms, const reply_target& to) {
    const auto deadline = earliest_deadline({in.received_ms, in.expiry_s, request.not_after_ms, signed_ts_ms},
                                            freshness_.max_age);
    if (!deadline) {
        // A read may come late; a change (a move above all) must say until when it may run.
        if (!descriptor_of(c).audited) return false;
        auto p = make_problem(make_error(operation_error_kind::invalid_value,
                                         "a command that changes something needs a deadline over MQTT: "
                                         "\"not_after\" (Unix milliseconds) or MQTT 5 message expiry",
                                         "not_after"));
        answer_error(to, request.id, std::move(p), in.topic);
        return true;
    }
    const auto now_ms = epoch_ms(std::chrono::system_clock::now());
    if (now_ms <= deadline->at_ms) return false;
    auto p = make_problem(make_error(operation_error_kind::stale_command,
                                     "not run: it arrived " + std::to_string(now_ms - deadline->at_ms) +
                                         " ms after its deadline (" + std::string(deadline->source) + ")"));
    answer_error(to, request.id, std::move(p), in.topic);
    return true;
}

bool mqtt_commands::is_redelivery(const mqtt_request& request, const auth_identity& who,
                                  const mqtt_message_in& in, const reply_target& to) {
    std::string key;
    if (request.id_given)
        key = "id " + request.id.dump();
    else if (!in.correlation_data.empty())
        key = "correlation " + in.correlation_data;
    else
        return false;  // nothing to know it by: a command without id or correlation data
    const auto now_ms = epoch_ms(std::chrono::system_clock::now());
    switch (delivered_.admit(who.name, key, now_ms, now_ms)) {
        case replay_window::verdict::fresh:
        case replay_window::verdict::stale:  // not with ts = now
            return false;
        case replay_window::verdict::replayed:
            drop(in.topic, "duplicate", who.name + "'s command " + key + " was taken before (a redelivery?)");
            return true;
        case replay_window::verdict::full: {
            // Not knowing a redelivery again, the gateway would risk running one twice: refused.
            auto p = make_problem(make_error(operation_error_kind::queue_full,
                                             "too many commands within mqtt.commands.redelivery_window_s to "
                                             "remember; try again later"));
            answer_error(to, request.id, std::move(p), in.topic);
            return true;
        }
    }
    return false;
}

std::optional<mqtt_commands::verified_command> mqtt_commands::verify_signed(const mqtt_message_in& in) {
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
        case replay_window::verdict::fresh:
            break;
        case replay_window::verdict::stale:
            drop(in.topic, "unauthenticated",
                 "ts " + std::to_string(c.ts_ms) + " is " + std::to_string((now_ms - c.ts_ms) / 1000) +
                     " s from the gateway's clock, outside mqtt.commands.signature_window_s (clocks in "
                     "sync?)");
            return std::nullopt;
        case replay_window::verdict::replayed:
            drop(in.topic, "replayed", "key \"" + c.key + "\" used nonce " + c.nonce + " before");
            return std::nullopt;
        case replay_window::verdict::full:
            drop(in.topic, "replayed", "too many signed commands within the window to remember");
            return std::nullopt;
    }
    return verified_command{auth_identity{key->name, key->role}, std::move(c.body), c.ts_ms};
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

void mqtt_commands::run(call c, const mqtt_request& request, const auth_identity& who,
                        const reply_target& to) {
    ++in_flight_;
    dispatch_call(*ctx_,
                  caller{who.name, who.role, mqtt_request_id(request.id), lease_of(request), "mqtt", {}},
                  std::move(c),
                  net::bind_executor(strand_, [self = shared_from_this(), to, id = request.id,
                                               topic = topics_.command(request.target)](api_outcome out) {
                      --self->in_flight_;
                      if (out.error) return self->answer_error(to, id, std::move(*out.error), topic);
                      self->answer(to, call_result_message(id, out.body, out.replayed), "ok");
                  }));
}

}  // namespace gw::api
