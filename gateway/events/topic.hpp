#pragma once
// Topic names and subscription filters of the event hub, MQTT style: levels separated by '/',
// "+" matches exactly one level, "#" matches the rest (only as the last level; "a/#" also matches "a").
//   names:   "controllers/stage1/position", "jobs/42"
//   filters: "controllers/+/position", "controllers/stage1/#", "jobs/#", "#"
// Pure functions: no I/O, no clock.

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <type_traits>
#include <vector>

#include <boost/system/error_code.hpp>

namespace gw {

inline constexpr std::size_t max_topic_bytes = 256;
inline constexpr std::size_t max_topic_levels = 16;

enum class topic_error {
    empty = 1,          // ""
    too_long,           // more than max_topic_bytes
    too_many_levels,    // more than max_topic_levels
    empty_level,        // "a//b", "/a", "a/"
    invalid_character,  // anything outside printable ASCII without space (0x21..0x7e)
    hash_not_last,      // "#/a", "a/#/b"
    wildcard_in_level,  // "+x", "a#", "x+y": a wildcard must be a whole level
    wildcard_in_name,   // a published topic name contains "+" or "#"
};

const boost::system::error_category& topic_error_category() noexcept;
boost::system::error_code make_error_code(topic_error e) noexcept;

// A subscription filter; wildcards allowed. Empty error_code when valid.
boost::system::error_code validate_topic_filter(std::string_view filter);
// A concrete topic a publisher uses; no wildcards. Empty error_code when valid.
boost::system::error_code validate_topic_name(std::string_view name);

// Both arguments are assumed valid (validate first); false for anything else.
bool topic_matches(std::string_view filter, std::string_view name);

// The levels of a topic, views into it: "controllers/sim1/state" -> {"controllers", "sim1", "state"};
// "a//b" -> {"a", "", "b"}. No validation. The one topic splitter (the MQTT side uses it too).
std::vector<std::string_view> topic_levels(std::string_view topic);

// What a topic is about, read once from its name (the one topic parser of the hub's names), so that a
// consumer of its events (the MQTT bridge) neither splits the name nor compares its levels.
enum class topic_kind : std::uint8_t {
    other,
    controller_state,     // controllers/<id>/state
    controller_position,  // controllers/<id>/position
    controller_reports,   // controllers/<id>/reports
    controller_ttl,       // controllers/<id>/ttl
    controller_errors,    // controllers/<id>/errors
    job,                  // jobs/<id>
    recording,            // recordings/<id>: a recording's new rows, every store flush
};
struct topic_address {
    topic_kind kind = topic_kind::other;
    // The controller's, the job's or the recording's id in the name: name.substr(key_at, key_size); empty for
    // other.
    std::size_t key_at = 0;
    std::size_t key_size = 0;
};
topic_address address_of(std::string_view name);
// The last level of a controller topic ("state", "position", "reports", "ttl", "errors"); "" otherwise.
std::string_view controller_leaf(topic_kind kind);
// Events of these kinds carry their data as a JSON value too (a controller's state, a job's records
// and steps): their consumers keep documents built from fields of it.
bool carries_document(topic_kind kind);

// How the hub treats a topic's events.
enum class topic_class : std::uint8_t {
    latest_value,  // "controllers/<id>/state", "controllers/<id>/position": newest wins, rate-limited
    stream,        // everything else ("reports", "ttl", "jobs/<id>"): never dropped silently
};
topic_class classify_topic(std::string_view name);

}  // namespace gw

template <>
struct boost::system::is_error_code_enum<gw::topic_error> : std::true_type {};
