#include "gateway/events/controller_events_bridge.hpp"

#include <optional>

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

controller_events_bridge::controller_events_bridge(std::shared_ptr<event_hub> hub) : hub_(std::move(hub)) {}

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
    hub_->publish(controller_topic(s.id, "state"), state_json(s), time);
    // A position event is stamped with when its positions were read: one published because only the
    // busy flags changed must not look newer than a step event published before it (the G-code trace
    // keeps positions by this time).
    auto read_at = known(s.positions_read);
    if (moved) hub_->publish(controller_topic(s.id, "position"), position, read_at ? read_at : time);
}

void controller_events_bridge::on_report(const devices::report_event& e) {
    hub_->publish(controller_topic(e.controller_id, "reports"), report_json(e), known(e.system_time));
}

void controller_events_bridge::on_ttl(const devices::ttl_event& e) {
    hub_->publish(controller_topic(e.controller_id, "ttl"), ttl_json(e), known(e.system_time));
}

void controller_events_bridge::forget(const std::string& id) {
    std::lock_guard lock(mutex_);
    last_position_.erase(id);
}

}  // namespace gw
