#include "gateway/events/controller_events_bridge.hpp"

#include <algorithm>
#include <optional>

#include "devices/ms2000/error_log.hpp"
#include "gateway/common/json_text.hpp"
#include "gateway/events/controller_state_texts.hpp"
#include "gateway/events/event_hub.hpp"
#include "gateway/events/event_json.hpp"

namespace gw {

namespace {

std::optional<std::chrono::system_clock::time_point> known(std::chrono::system_clock::time_point t) {
    if (t == std::chrono::system_clock::time_point{}) return std::nullopt;  // let the hub stamp it
    return t;
}

}  // namespace

std::string controller_topic(std::string_view id, std::string_view leaf) {
    std::string topic = "controllers/";
    topic += id;
    topic += '/';
    topic += leaf;
    return topic;
}

controller_events_bridge::controller_events_bridge(std::shared_ptr<event_hub> hub,
                                                   std::shared_ptr<controller_state_texts> state_texts)
    : hub_(std::move(hub)), state_texts_(std::move(state_texts)) {}

nlohmann::json controller_events_bridge::identity_of(const devices::controller_snapshot& s) {
    if (!s.identity) return nullptr;
    std::lock_guard lock(mutex_);
    auto it = identities_.find(s.id);
    if (it == identities_.end() || it->second.identity != *s.identity)
        it =
            identities_.insert_or_assign(s.id, known_identity{*s.identity, identity_json(*s.identity)}).first;
    return it->second.json;
}

void controller_events_bridge::on_snapshot(const devices::controller_snapshot& s) {
    auto time = known(s.updated);
    auto position = position_json(s);
    bool moved = false;
    {
        std::lock_guard lock(mutex_);
        auto [it, inserted] = last_position_.try_emplace(s.id);
        if (inserted || it->second != position) {
            it->second = position;
            moved = true;
        }
    }
    auto state = std::make_shared<const std::string>(to_json_text(state_json(s, identity_of(s))));
    if (state_texts_) state_texts_->set(s.id, state);
    hub_->publish(controller_topic(s.id, "state"), std::move(state), time);
    // A position event is stamped with when its positions were read: one published because only the
    // busy flags changed must not look newer than a step event published before it (the G-code trace
    // keeps positions by this time).
    auto read_at = known(s.positions_read);
    if (moved) hub_->publish(controller_topic(s.id, "position"), position, read_at ? read_at : time);
}

void controller_events_bridge::on_report(const devices::report_event& e) {
    hub_->publish(controller_topic(e.controller_id, "reports"),
                  std::make_shared<const std::string>(report_json_text(e)), known(e.system_time));
}

void controller_events_bridge::on_ttl(const devices::ttl_event& e) {
    hub_->publish(controller_topic(e.controller_id, "ttl"), ttl_json(e), known(e.system_time));
}

void controller_events_bridge::on_error_log(const devices::error_log_event& e) {
    hub_->publish(controller_topic(e.controller_id, "errors"), error_log_json(e), known(e.system_time));
    const auto overruns = static_cast<std::uint64_t>(
        std::count(e.codes.begin(), e.codes.end(), devices::ms2000::ttl_report_buffer_overrun));
    if (overruns != 0)
        hub_->publish(controller_topic(e.controller_id, "reports"), report_overrun_json(e, overruns),
                      known(e.system_time));
}

void controller_events_bridge::forget(const std::string& id) {
    std::lock_guard lock(mutex_);
    last_position_.erase(id);
    identities_.erase(id);
    if (state_texts_) state_texts_->forget(id);
}

}  // namespace gw
