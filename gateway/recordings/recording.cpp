#include "gateway/recordings/recording.hpp"

#include <array>

#include "gateway/common/timestamp.hpp"

namespace gw::recordings {

namespace {

constexpr std::array<std::string_view, 3> state_names = {"recording", "stopped", "failed"};
constexpr std::array<std::string_view, 4> loss_names = {"none", "garbled", "disconnected", "overrun"};

}  // namespace

std::string_view to_string(recording_state s) {
    return state_names[static_cast<std::size_t>(s)];
}

std::optional<recording_state> parse_recording_state(std::string_view text) {
    for (std::size_t i = 0; i < state_names.size(); ++i)
        if (state_names[i] == text) return static_cast<recording_state>(i);
    return std::nullopt;
}

std::string_view to_string(loss_kind k) {
    return loss_names[static_cast<std::size_t>(k)];
}

nlohmann::json to_json(const recording_record& r) {
    using clock = std::chrono::system_clock;
    const auto at = [](std::int64_t ms) {
        return format_timestamp(clock::time_point(std::chrono::milliseconds(ms)));
    };
    nlohmann::json j{{"id", r.id},
                     {"controller", r.controller},
                     {"name", r.name},
                     {"state", to_string(r.state)},
                     {"reason", r.reason},
                     {"started", at(r.started_ms)},
                     {"stopped", r.stopped_ms ? nlohmann::json(at(*r.stopped_ms)) : nlohmann::json(nullptr)},
                     {"frames", r.frames},
                     {"losses", r.losses},
                     {"axes", r.axes},
                     {"ttl_in_mode", r.ttl_in_mode},
                     {"metadata", r.metadata}};
    j["max_frames"] = r.max_frames ? nlohmann::json(*r.max_frames) : nlohmann::json(nullptr);
    j["max_s"] = r.max_s ? nlohmann::json(*r.max_s) : nlohmann::json(nullptr);
    j["job"] = r.job ? nlohmann::json(*r.job) : nlohmann::json(nullptr);
    const auto end_ms = r.stopped_ms.value_or(r.started_ms);
    const double seconds = static_cast<double>(end_ms - r.started_ms) / 1000.0;
    j["rate_hz"] = r.stopped_ms && seconds > 0 ? nlohmann::json(static_cast<double>(r.frames) / seconds)
                                               : nlohmann::json(nullptr);
    return j;
}

}  // namespace gw::recordings
