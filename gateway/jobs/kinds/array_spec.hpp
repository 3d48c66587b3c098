#pragma once
// The spec of an `array` job (openapi/openapi.yaml, schema ArraySpec), parsed strictly: an unknown field, a
// wrong type or an out-of-range value is invalid_value with `field` = "spec.<path>". Pure.

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gateway/common/operation_error.hpp"
#include "gateway/jobs/job_context.hpp"
#include "gateway/jobs/kinds/plate.hpp"

namespace gw::jobs {

enum class run_mode : std::uint8_t { automatic, firmware, host };

struct array_spec {
    std::optional<std::string> plate;  // preset name when the geometry came from "plate"
    plate_geometry geometry;
    std::optional<std::pair<double, double>> a1_um;  // empty: "current" (the position at job start)
    double rotation_deg = 0;
    well_order order = well_order::serpentine;
    std::vector<well_index> wells;  // subset as given (validated, unique); empty = every well
    double dwell_ms = 0;            // whole milliseconds (an integer in the spec)
    advance_source advance = advance_source::timer;
    bool ttl_pulse = false;
    std::optional<well_index> resume_from;
    run_mode mode = run_mode::automatic;

    // The wells to visit, in visit order (the subset filtered in plate order).
    std::vector<well_index> visits() const;
};

inline constexpr double max_array_step_mm = 1000;
inline constexpr long long max_array_dwell_ms = 24LL * 3600 * 1000;  // whole milliseconds
inline constexpr std::size_t max_array_wells = 100000;

operation_result<array_spec> parse_array_spec(const nlohmann::json& spec);

}  // namespace gw::jobs
