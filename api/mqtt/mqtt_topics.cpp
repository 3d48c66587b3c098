#include "api/mqtt/mqtt_topics.hpp"

#include <array>
#include <utility>

#include "gateway/events/topic.hpp"

namespace gw::api {

namespace {

constexpr std::array<std::pair<mqtt_command_kind, std::string_view>, 5> job_commands = {{
    {mqtt_command_kind::job_submit, "submit"},
    {mqtt_command_kind::job_cancel, "cancel"},
    {mqtt_command_kind::job_pause, "pause"},
    {mqtt_command_kind::job_resume, "resume"},
    {mqtt_command_kind::job_next, "next"},
}};

bool is_id_level(std::string_view s) {
    return !s.empty() && s.find_first_of("+#") == std::string_view::npos;
}

}  // namespace

std::string_view to_string(mqtt_command_kind k) {
    for (const auto& [kind, name] : job_commands)
        if (kind == k) return name;
    if (k == mqtt_command_kind::gcode_check) return "check";
    return k == mqtt_command_kind::halt_all ? "halt" : "command";
}

mqtt_topics::mqtt_topics(std::string prefix, std::string gateway_id)
    : prefix_(std::move(prefix)), gateway_(std::move(gateway_id)), base_(prefix_ + "/" + gateway_) {}

std::string mqtt_topics::status() const {
    return base_ + "/status";
}

std::string mqtt_topics::controller(std::string_view id, std::string_view leaf) const {
    std::string t = base_;
    t += "/controllers/";
    t += id;
    t += '/';
    t += leaf;
    return t;
}

std::string mqtt_topics::job_state(std::string_view job_id) const {
    std::string t = base_;
    t += "/jobs/";
    t += job_id;
    t += "/state";
    return t;
}

std::string mqtt_topics::recording(std::string_view recording_id) const {
    return base_ + "/recordings/" + std::string(recording_id);
}

std::string mqtt_topics::job_command(mqtt_command_kind kind) const {
    return base_ + "/jobs/" + std::string(to_string(kind));
}

std::string mqtt_topics::gcode_check() const {
    return base_ + "/gcode/check";
}

std::string mqtt_topics::halt_all() const {
    return base_ + "/halt";
}

std::string mqtt_topics::command(const mqtt_command_target& target) const {
    switch (target.kind) {
        case mqtt_command_kind::controller:
            return controller(target.controller, "cmd");
        case mqtt_command_kind::gcode_check:
            return gcode_check();
        case mqtt_command_kind::halt_all:
            return halt_all();
        default:
            return job_command(target.kind);
    }
}

std::vector<std::string> mqtt_topics::command_filters() const {
    std::vector<std::string> out{base_ + "/controllers/+/cmd"};
    for (const auto& [kind, name] : job_commands)
        out.push_back(job_command(kind));
    out.push_back(gcode_check());
    out.push_back(halt_all());
    return out;
}

std::optional<mqtt_command_target> mqtt_topics::parse_command_topic(std::string_view topic) const {
    if (!topic.starts_with(base_) || topic.size() <= base_.size() || topic[base_.size()] != '/')
        return std::nullopt;
    const auto rest = topic_levels(topic.substr(base_.size() + 1));
    if (rest.size() == 3 && rest[0] == "controllers" && is_id_level(rest[1]) && rest[2] == "cmd")
        return mqtt_command_target{mqtt_command_kind::controller, std::string(rest[1])};
    if (rest.size() == 2 && rest[0] == "jobs")
        for (const auto& [kind, name] : job_commands)
            if (rest[1] == name) return mqtt_command_target{kind, {}};
    if (rest.size() == 2 && rest[0] == "gcode" && rest[1] == "check")
        return mqtt_command_target{mqtt_command_kind::gcode_check, {}};
    if (rest.size() == 1 && rest[0] == "halt") return mqtt_command_target{mqtt_command_kind::halt_all, {}};
    return std::nullopt;
}

std::optional<std::string> mqtt_topics::for_hub_topic(topic_kind kind, std::string_view key) const {
    if (!is_id_level(key)) return std::nullopt;
    if (kind == topic_kind::job) return job_state(key);
    if (kind == topic_kind::recording) return recording(key);
    if (const auto leaf = controller_leaf(kind); !leaf.empty()) return controller(key, leaf);
    return std::nullopt;
}

bool mqtt_topics::is_allowed_reply_topic(std::string_view topic) const {
    if (validate_topic_name(topic) || topic.front() == '$') return false;
    return !(topic == prefix_ || (topic.starts_with(prefix_) && topic[prefix_.size()] == '/'));
}

std::string resolve_gateway_id(std::string_view configured, std::string_view hostname) {
    if (!configured.empty()) return std::string(configured);
    std::string id;
    for (char c : hostname.substr(0, 64)) {
        const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                        c == '-' || c == '_' || c == '.';
        id += ok ? c : '-';
    }
    if (id.empty() || id.front() == '$') id = "gateway";
    return id;
}

}  // namespace gw::api
