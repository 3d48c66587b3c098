#pragma once
// The MQTT topic tree of one gateway, and the mapping from event hub topics to it. Pure.
//
//   <prefix>/<gateway>/status                         retained birth / will / offline
//   <prefix>/<gateway>/controllers/<id>/state         retained snapshot
//   <prefix>/<gateway>/controllers/<id>/position      rate-limited
//   <prefix>/<gateway>/controllers/<id>/reports       batched encoder report frames
//   <prefix>/<gateway>/controllers/<id>/ttl           TTL events
//   <prefix>/<gateway>/jobs/<job>/state               retained while active, cleared when old
//   <prefix>/<gateway>/recordings/<recording>         a recording's new rows, every store flush
// Commands (subscribed only when mqtt.commands.enabled):
//   <prefix>/<gateway>/controllers/<id>/cmd
//   <prefix>/<gateway>/jobs/submit | cancel | pause | resume | next
//   <prefix>/<gateway>/gcode/check
//   <prefix>/<gateway>/halt                           HALT ALL

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gateway/events/topic.hpp"

namespace gw::api {

enum class mqtt_command_kind {
    controller,
    job_submit,
    job_cancel,
    job_pause,
    job_resume,
    job_next,
    gcode_check,
    halt_all
};

// "submit", "cancel", ... (the job action; "check" for gcode_check; "halt" for halt_all; "command" for
// controller).
std::string_view to_string(mqtt_command_kind k);

struct mqtt_command_target {
    mqtt_command_kind kind = mqtt_command_kind::controller;
    std::string controller;  // kind controller: the <id> level
};

class mqtt_topics {
  public:
    // Both must be valid (gw::is_valid_mqtt_prefix, gw::is_valid_mqtt_level).
    mqtt_topics(std::string prefix, std::string gateway_id);

    const std::string& prefix() const { return prefix_; }
    const std::string& gateway_id() const { return gateway_; }
    const std::string& base() const { return base_; }  // "<prefix>/<gateway>"

    std::string status() const;
    // leaf: "state", "position", "reports", "ttl", "cmd".
    std::string controller(std::string_view id, std::string_view leaf) const;
    std::string job_state(std::string_view job_id) const;
    std::string recording(std::string_view recording_id) const;
    std::string job_command(mqtt_command_kind kind) const;  // "<base>/jobs/submit"...
    std::string gcode_check() const;                        // "<base>/gcode/check"
    std::string halt_all() const;                           // "<base>/halt"
    // The topic a command for `target` comes on (one of the above, or controller(id, "cmd")).
    std::string command(const mqtt_command_target& target) const;

    // What the gateway subscribes to when commands are enabled.
    std::vector<std::string> command_filters() const;
    // The target of a message received on `topic`, or nullopt for a topic that is not a command topic
    // of this gateway.
    std::optional<mqtt_command_target> parse_command_topic(std::string_view topic) const;

    // The MQTT topic of an event hub topic (an event's address: its kind and key):
    // "controllers/<id>/<leaf>" -> controller(id, leaf), "jobs/<job>" -> job_state(job),
    // "recordings/<id>" -> recording(id). nullopt for
    // anything else.
    std::optional<std::string> for_hub_topic(topic_kind kind, std::string_view key) const;

    // Where a response may go: a valid topic name (no wildcards, not "$..."), outside the fleet tree
    // "<prefix>/..." so that no client can make the gateway overwrite a state or status topic.
    bool is_allowed_reply_topic(std::string_view topic) const;

  private:
    std::string prefix_;
    std::string gateway_;
    std::string base_;
};

// The gateway id to use: `configured` when set, else `hostname` with every character outside
// [A-Za-z0-9_.-] replaced by '-', cut to 64 characters ("gateway" when nothing is left).
std::string resolve_gateway_id(std::string_view configured, std::string_view hostname);

}  // namespace gw::api
