#include "gateway/events/topic.hpp"

#include <string>

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

topic_class classify_topic(std::string_view name) {
    constexpr std::string_view prefix = "controllers/";
    if (!name.starts_with(prefix)) return topic_class::stream;
    name.remove_prefix(prefix.size());
    auto slash = name.find('/');
    if (slash == std::string_view::npos || slash == 0) return topic_class::stream;
    auto leaf = name.substr(slash + 1);
    return leaf == "state" || leaf == "position" ? topic_class::latest_value : topic_class::stream;
}

std::vector<std::string_view> topic_levels(std::string_view topic) {
    std::vector<std::string_view> out;
    bool more = true;
    while (more)
        out.push_back(next_level(topic, more));
    return out;
}

}  // namespace gw
