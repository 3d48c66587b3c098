#pragma once
// One event as the hub hands it to subscribers: an immutable value shared by every subscriber.
// `message` is the complete JSON text a transport sends as is (a WebSocket text frame, an MQTT
// payload); it is serialised once, when the hub assigns the sequence number.
//   data: {"type":"event","topic":"controllers/stage1/position","seq":12,
//          "time":"2026-11-22T02:45:40.123Z","time_ms":1795322740123,"data":{...}}
//   gap:  {"type":"gap","topic":"controllers/stage1/reports","missed":40,"from":101,"to":140,
//          "time":"2026-11-22T02:45:40.456Z","time_ms":1795322740456}
//   retired: {"type":"retired","topic":"jobs/j-01M8...","last_seq":9,
//          "time":"2026-11-22T02:55:40.456Z","time_ms":1795323340456}
// A gap event tells one subscriber that the events from..to of that topic will not reach it (they
// left the replay buffer, or its queue overflowed). A retired event tells it that the topic has left
// the hub after its events 1..last_seq (event_hub::retire_topic): nothing more comes on it, and
// what it missed is not replayed any more (a job's history: GET /api/v1/jobs/{id}/events). Gap and
// retired events are per subscriber, never replayed.

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include <nlohmann/json_fwd.hpp>

#include "gateway/events/topic.hpp"

namespace gw {

enum class event_kind : std::uint8_t { data, gap, retired };

struct event {
    event_kind kind = event_kind::data;
    std::string topic;
    std::uint64_t sequence = 0;  // data: 1, 2, 3 ... per topic; gap: 0; retired: the topic's last
    std::uint64_t gap_from = 0;  // gap: first missed sequence number
    std::uint64_t gap_to = 0;    // gap: last missed sequence number
    std::chrono::system_clock::time_point time;
    std::shared_ptr<const std::string> data;     // data: the payload's JSON text
    std::shared_ptr<const std::string> message;  // the whole JSON message (see above)
    topic_address address;                       // what the topic is about (address_of), for consumers
    // data, for the kinds that carry_document (a controller's state, a job's events): the payload as a
    // JSON value, so that a consumer reads its fields without parsing the text. Null otherwise.
    std::shared_ptr<const nlohmann::json> document;

    std::uint64_t missed() const { return kind == event_kind::gap ? gap_to - gap_from + 1 : 0; }
    // The controller's or the job's id of the topic; empty for other topics.
    std::string_view key() const { return std::string_view(topic).substr(address.key_at, address.key_size); }
};

// `data` must be one valid JSON value (it is embedded as is, not re-parsed); `document`, when given, the
// same value.
std::shared_ptr<const event> make_data_event(std::string topic, std::uint64_t sequence,
                                             std::chrono::system_clock::time_point time,
                                             std::shared_ptr<const std::string> data,
                                             std::shared_ptr<const nlohmann::json> document = {});
std::shared_ptr<const event> make_gap_event(std::string topic, std::uint64_t from, std::uint64_t to,
                                            std::chrono::system_clock::time_point time);
std::shared_ptr<const event> make_retired_event(std::string topic, std::uint64_t last_sequence,
                                                std::chrono::system_clock::time_point time);

}  // namespace gw
