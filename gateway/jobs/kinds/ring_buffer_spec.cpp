#include "gateway/jobs/kinds/ring_buffer_spec.hpp"

#include <cctype>
#include <cmath>
#include <fmt/format.h>

#include "gateway/common/json_value.hpp"
#include "gateway/controllers/operations.hpp"
#include "gateway/jobs/kinds/spec_fields.hpp"

namespace gw::jobs {

namespace {

using json = nlohmann::json;

bool is_axis_key(const std::string& key) {
    return key.size() == 1 && std::isupper(static_cast<unsigned char>(key[0]));
}

}  // namespace

operation_result<ring_buffer_spec> parse_ring_buffer_spec(const json& spec) {
    if (!spec.is_object())
        return make_error(operation_error_kind::invalid_value, "spec must be an object", "spec");
    if (auto known = spec_known_fields(
            spec, "", {"positions", "axes", "trigger", "delay_ms", "repeat", "cycles", "mode", "record"});
        !known)
        return known.error();
    ring_buffer_spec s;

    if (!spec.contains("positions")) return spec_error("positions", "positions is required");
    const auto& positions = spec["positions"];
    if (!positions.is_array() || positions.empty())
        return spec_error("positions", R"(positions must be a non-empty array of {"X": um, "Y": um})");
    if (positions.size() > max_ring_buffer_positions)
        return spec_error("positions", fmt::format("at most {} positions", max_ring_buffer_positions));
    std::string named;  // every axis named by some position, in order of appearance
    for (std::size_t i = 0; i < positions.size(); ++i) {
        const auto& p = positions[i];
        const std::string field = fmt::format("positions[{}]", i);
        if (!p.is_object() || p.empty())
            return spec_error(field,
                              fmt::format(R"({} must be an object of axis positions {{"X": um}})", field));
        position_um pos;
        for (const auto& [key, value] : p.items()) {
            const auto key_field = fmt::format("{}.{}", field, key);
            if (!is_axis_key(key))
                return spec_error(key_field, fmt::format("{}: {} is not an axis letter", field, key));
            const auto um = read_number(value, -max_travel_um, max_travel_um);
            if (!um)
                return spec_error(key_field, fmt::format("{} must be a number of micrometres within +-{}",
                                                         key_field, max_travel_um));
            pos[key[0]] = *um.value;
            if (named.find(key[0]) == std::string::npos) named += key[0];
        }
        s.positions.push_back(std::move(pos));
    }

    if (spec.contains("axes")) {
        const auto& a = spec["axes"];
        if (!a.is_string() || a.get<std::string>().empty())
            return spec_error("axes", "axes must be a string of axis letters (\"XY\")");
        for (char c : a.get<std::string>()) {
            const char upper = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
            if (!std::isalpha(static_cast<unsigned char>(c)))
                return spec_error("axes", fmt::format("axes: '{}' is not an axis letter", c));
            if (s.axes.find(upper) != std::string::npos)
                return spec_error("axes", fmt::format("axes: {} is listed twice", upper));
            s.axes += upper;
        }
    } else {
        s.axes = named;
    }
    // Every position names exactly the mask's axes: the buffer moves those axes at every position.
    for (std::size_t i = 0; i < s.positions.size(); ++i) {
        for (const auto& [axis, um] : s.positions[i])
            if (s.axes.find(axis) == std::string::npos)
                return spec_error(
                    fmt::format("positions[{}].{}", i, axis),
                    fmt::format("positions[{}] names {}, which is not in axes {}", i, axis, s.axes));
        for (char axis : s.axes)
            if (!s.positions[i].contains(axis))
                return spec_error(fmt::format("positions[{}].{}", i, axis),
                                  fmt::format("positions[{}] needs {} (axes {})", i, axis, s.axes));
    }

    if (spec.contains("trigger")) {
        const auto& t = spec["trigger"];
        if (t == "autoplay")
            s.trigger = ring_buffer_spec::trigger_kind::autoplay;
        else if (t == "ttl")
            s.trigger = ring_buffer_spec::trigger_kind::ttl;
        else if (t == "next")
            s.trigger = ring_buffer_spec::trigger_kind::next;
        else
            return spec_error("trigger", "trigger must be \"autoplay\", \"ttl\" or \"next\"");
    }
    if (spec.contains("delay_ms")) {
        const auto d = read_number(spec["delay_ms"], 0, max_ring_buffer_delay_ms);
        if (!d)
            return spec_error("delay_ms",
                              fmt::format("delay_ms must be between 0 and {}", max_ring_buffer_delay_ms));
        if (s.trigger != ring_buffer_spec::trigger_kind::autoplay)
            return spec_error("delay_ms", "delay_ms applies to trigger \"autoplay\" only");
        s.delay_ms = *d.value;
    }
    if (spec.contains("repeat")) {
        if (!spec["repeat"].is_boolean()) return spec_error("repeat", "repeat must be true or false");
        s.repeat = spec["repeat"].get<bool>();
    }
    if (spec.contains("cycles")) {
        const auto c = read_integer(spec["cycles"], 0, max_ring_buffer_cycles);
        if (!c)
            return spec_error(
                "cycles", fmt::format("cycles must be an integer between 0 and {}", max_ring_buffer_cycles));
        s.cycles = static_cast<int>(*c.value);
        if (!s.repeat && s.cycles != 1)
            return spec_error("cycles", "cycles other than 1 needs \"repeat\": true");
    } else if (s.repeat) {
        s.cycles = 0;  // repeating: until cancelled
    }
    if (s.positions.size() * static_cast<std::size_t>(s.tours()) > 100'000)
        return spec_error("cycles", "positions x cycles must not exceed 100000 steps");
    if (spec.contains("mode")) {
        const auto& m = spec["mode"];
        if (m == "auto")
            s.mode = ring_buffer_spec::path_mode::automatic;
        else if (m == "firmware")
            s.mode = ring_buffer_spec::path_mode::firmware;
        else if (m == "host")
            s.mode = ring_buffer_spec::path_mode::host;
        else
            return spec_error("mode", "mode must be \"auto\", \"firmware\" or \"host\"");
    }
    return s;
}

}  // namespace gw::jobs
