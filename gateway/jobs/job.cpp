#include "gateway/jobs/job.hpp"

#include <array>
#include <utility>

namespace gw::jobs {

namespace {

constexpr std::array<std::pair<job_type, std::string_view>, 5> type_names{{
    {job_type::array, "array"},
    {job_type::scan, "scan"},
    {job_type::ring_buffer, "ring_buffer"},
    {job_type::planar_correction, "planar_correction"},
    {job_type::gcode, "gcode"},
}};

constexpr std::array<std::pair<job_state, std::string_view>, 7> state_names{{
    {job_state::queued, "queued"},
    {job_state::running, "running"},
    {job_state::paused, "paused"},
    {job_state::succeeded, "succeeded"},
    {job_state::failed, "failed"},
    {job_state::cancelled, "cancelled"},
    {job_state::interrupted, "interrupted"},
}};

constexpr std::array<std::pair<job_wait, std::string_view>, 6> wait_names{{
    {job_wait::next, "next"},
    {job_wait::ttl, "ttl"},
    {job_wait::timer, "timer"},
    {job_wait::controller, "controller"},
    {job_wait::storage, "storage"},
    {job_wait::halt, "halt"},
}};

template <typename Enum, std::size_t N>
std::string_view name_of(const std::array<std::pair<Enum, std::string_view>, N>& names, Enum value) {
    for (const auto& [v, name] : names)
        if (v == value) return name;
    return "unknown";
}

template <typename Enum, std::size_t N>
std::optional<Enum> value_of(const std::array<std::pair<Enum, std::string_view>, N>& names,
                             std::string_view s) {
    for (const auto& [v, name] : names)
        if (name == s) return v;
    return std::nullopt;
}

}  // namespace

std::string_view to_string(job_type t) {
    return name_of(type_names, t);
}
std::optional<job_type> parse_job_type(std::string_view s) {
    return value_of(type_names, s);
}
std::string_view to_string(job_state s) {
    return name_of(state_names, s);
}
std::optional<job_state> parse_job_state(std::string_view s) {
    return value_of(state_names, s);
}

std::string_view to_string(job_wait w) {
    return name_of(wait_names, w);
}

bool is_unbounded(job_wait w) {
    return w != job_wait::timer;
}

bool is_terminal(job_state s) {
    return s == job_state::succeeded || s == job_state::failed || s == job_state::cancelled;
}

}  // namespace gw::jobs
