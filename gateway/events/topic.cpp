#include "gateway/events/topic.hpp"

#include <string>
#include <utility>

namespace gw {

namespace {

class topic_category final : public boost::system::error_category {
  public:
    const char* name() const noexcept override { return "gw.topic"; }
    std::string message(int ev) const override {
        switch (static_cast<topic_error>(ev)) {
            case topic_error::empty:
                return "empty topic";
            case topic_error::too_long:
                return "topic longer than " + std::to_string(max_topic_bytes) + " bytes";
            case topic_error::too_many_levels:
                return "topic has more than " + std::to_string(max_topic_levels) + " levels";
            case topic_error::empty_level:
                return "topic has an empty level";
            case topic_error::invalid_character:
                return "topic has a character outside printable ASCII (or a space)";
            case topic_error::hash_not_last:
                return "'#' is only allowed as the last level";
            case topic_error::wildcard_in_level:
                return "a wildcard must be a whole level ('+' or '#')";
            case topic_error::wildcard_in_name:
                return "a topic name cannot contain '+' or '#'";
        }
        return "unknown topic error";
    }
};

// Splits off the next level; `rest` is left without it and without the separator.
std::string_view next_level(std::string_view& rest, bool& more) {
    auto slash = rest.find('/');
    if (slash == std::string_view::npos) {
        auto level = rest;
        rest = {};
        more = false;
        return level;
    }
    auto level = rest.substr(0, slash);
    rest.remove_prefix(slash + 1);
    more = true;
    return level;
}

boost::system::error_code validate(std::string_view topic, bool wildcards) {
    if (topic.empty()) return topic_error::empty;
    if (topic.size() > max_topic_bytes) return topic_error::too_long;
    for (char c : topic)
        if (c < 0x21 || c > 0x7e) return topic_error::invalid_character;
    std::size_t levels = 0;
    bool more = true;
    while (more) {
        auto level = next_level(topic, more);
        if (++levels > max_topic_levels) return topic_error::too_many_levels;
        if (level.empty()) return topic_error::empty_level;
        bool has_plus = level.find('+') != std::string_view::npos;
        bool has_hash = level.find('#') != std::string_view::npos;
        if (!has_plus && !has_hash) continue;
        if (!wildcards) return topic_error::wildcard_in_name;
        if (level.size() != 1) return topic_error::wildcard_in_level;
        if (has_hash && more) return topic_error::hash_not_last;
    }
    return {};
}

}  // namespace

const boost::system::error_category& topic_error_category() noexcept {
    static const topic_category category;
    return category;
}

boost::system::error_code make_error_code(topic_error e) noexcept {
    return {static_cast<int>(e), topic_error_category()};
}

boost::system::error_code validate_topic_filter(std::string_view filter) {
    return validate(filter, true);
}

boost::system::error_code validate_topic_name(std::string_view name) {
    return validate(name, false);
}

bool topic_matches(std::string_view filter, std::string_view name) {
    bool filter_more = true;
    bool name_more = true;
    while (filter_more) {
        auto f = next_level(filter, filter_more);
        if (f == "#") return true;  // the rest, including nothing ("a/#" matches "a")
        if (!name_more) return false;
        auto n = next_level(name, name_more);
        if (f != "+" && f != n) return false;
    }
    return !name_more;
}

topic_address address_of(std::string_view name) {
    const auto levels = topic_levels(name);
    auto at = [&](std::size_t i) { return static_cast<std::size_t>(levels[i].data() - name.data()); };
    if (levels.size() == 2 && levels[0] == "jobs" && !levels[1].empty())
        return {topic_kind::job, at(1), levels[1].size()};
    if (levels.size() == 2 && levels[0] == "recordings" && !levels[1].empty())
        return {topic_kind::recording, at(1), levels[1].size()};
    if (levels.size() != 3 || levels[0] != "controllers" || levels[1].empty()) return {};
    static constexpr std::pair<std::string_view, topic_kind> leaves[] = {
        {"state", topic_kind::controller_state},     {"position", topic_kind::controller_position},
        {"reports", topic_kind::controller_reports}, {"ttl", topic_kind::controller_ttl},
        {"errors", topic_kind::controller_errors},
    };
    for (const auto& [leaf, kind] : leaves)
        if (levels[2] == leaf) return {kind, at(1), levels[1].size()};
    return {};
}

std::string_view controller_leaf(topic_kind kind) {
    switch (kind) {
        case topic_kind::controller_state:
            return "state";
        case topic_kind::controller_position:
            return "position";
        case topic_kind::controller_reports:
            return "reports";
        case topic_kind::controller_ttl:
            return "ttl";
        case topic_kind::controller_errors:
            return "errors";
        case topic_kind::other:
        case topic_kind::job:
        case topic_kind::recording:
            break;
    }
    return {};
}

bool carries_document(topic_kind kind) {
    return kind == topic_kind::controller_state || kind == topic_kind::job;
}

topic_class classify_topic(std::string_view name) {
    const auto kind = address_of(name).kind;
    return kind == topic_kind::controller_state || kind == topic_kind::controller_position
               ? topic_class::latest_value
               : topic_class::stream;
}

std::vector<std::string_view> topic_levels(std::string_view topic) {
    std::vector<std::string_view> out;
    bool more = true;
    while (more)
        out.push_back(next_level(topic, more));
    return out;
}

}  // namespace gw
