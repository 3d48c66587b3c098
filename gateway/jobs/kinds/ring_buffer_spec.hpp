#pragma once
// The spec of a `ring_buffer` job (openapi/openapi.yaml, schema RingBufferSpec), parsed strictly: an unknown
// field, a wrong type or an out-of-range value is invalid_value with `field` = "spec.<path>". Pure.
// The buffer's capacity depends on the controller (BU X "RING BUFFER [size]"); the planner checks it.

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gateway/common/operation_error.hpp"
#include "gateway/jobs/job_plan.hpp"

namespace gw::jobs {

inline constexpr std::size_t default_ring_buffer_capacity = 50;  // seed: "up to 50 locations"
inline constexpr std::size_t max_ring_buffer_positions = 1000;   // parse bound; the plan checks capacity
inline constexpr int max_ring_buffer_cycles = 1'000'000;
inline constexpr double max_ring_buffer_delay_ms = 24.0 * 3600 * 1000;

struct ring_buffer_spec {
    enum class path_mode : std::uint8_t { automatic, firmware, host };
    enum class trigger_kind : std::uint8_t { autoplay, ttl, next };

    std::vector<position_um> positions;  // micrometres; every position names exactly the mask axes
    std::string axes;                    // the axis mask, upper-case letters in the order given
    trigger_kind trigger = trigger_kind::autoplay;
    double delay_ms = 0;  // autoplay only: after each arrival, before the next move
    bool repeat = false;  // after the last position, continue with the first
    int cycles = 1;       // tours; 0 = until cancelled (repeat only; the default with repeat)
    path_mode mode = path_mode::automatic;

    bool forever() const { return repeat && cycles == 0; }
    int tours() const { return forever() ? 1 : cycles; }  // tours in the plan's step list
};

operation_result<ring_buffer_spec> parse_ring_buffer_spec(const nlohmann::json& spec);

}  // namespace gw::jobs
