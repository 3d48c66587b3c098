#include "gateway/jobs/kinds/array_spec.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <set>

#include "gateway/common/json_keys.hpp"
#include "gateway/controllers/operations.hpp"
#include "gateway/jobs/kinds/spec_fields.hpp"

namespace gw::jobs {

namespace {

using json = nlohmann::json;

operation_result<plate_geometry> parse_grid(const json& grid) {
    if (!grid.is_object())
        return spec_error("grid", "grid must be an object {columns, rows, column_step_mm, row_step_mm}");
    if (auto known = spec_known_fields(grid, "grid.", {"columns", "rows", "column_step_mm", "row_step_mm"});
        !known)
        return known.error();
    plate_geometry g;
    for (const char* key : {"columns", "rows", "column_step_mm", "row_step_mm"})
        if (!grid.contains(key))
            return spec_error(std::string("grid.") + key, fmt::format("grid.{} is required", key));
    auto columns = spec_integer(grid["columns"], "grid.columns", 1, max_plate_columns);
    if (!columns) return columns.error();
    auto rows = spec_integer(grid["rows"], "grid.rows", 1, max_plate_rows);
    if (!rows) return rows.error();
    if (static_cast<std::size_t>(*columns) * static_cast<std::size_t>(*rows) > max_array_wells)
        return spec_error("grid", fmt::format("a grid has at most {} wells", max_array_wells));
    auto cs =
        spec_number(grid["column_step_mm"], "grid.column_step_mm", -max_array_step_mm, max_array_step_mm);
    if (!cs) return cs.error();
    auto rs = spec_number(grid["row_step_mm"], "grid.row_step_mm", -max_array_step_mm, max_array_step_mm);
    if (!rs) return rs.error();
    if (*cs == 0 && *columns > 1)
        return spec_error("grid.column_step_mm", "grid.column_step_mm must not be 0");
    if (*rs == 0 && *rows > 1) return spec_error("grid.row_step_mm", "grid.row_step_mm must not be 0");
    g.columns = *columns;
    g.rows = *rows;
    g.column_step_mm = *cs;
    g.row_step_mm = *rs;
    return g;
}

operation_result<std::pair<double, double>> parse_a1(const json& a1) {
    if (!a1.is_object()) return spec_error("a1", R"(a1 must be {"X": um, "Y": um} or "current")");
    if (const auto key = first_unknown_key(a1, {"X", "Y"}))
        return spec_error("a1." + *key, fmt::format("a1 takes X and Y only, not {}", *key));
    if (!a1.contains("X")) return spec_error("a1.X", "a1.X is required");
    if (!a1.contains("Y")) return spec_error("a1.Y", "a1.Y is required");
    auto x = spec_number(a1["X"], "a1.X", -max_travel_um, max_travel_um);
    if (!x) return x.error();
    auto y = spec_number(a1["Y"], "a1.Y", -max_travel_um, max_travel_um);
    if (!y) return y.error();
    return std::pair{*x, *y};
}

}  // namespace

std::vector<well_index> array_spec::visits() const {
    auto all = visit_order(geometry, order);
    if (wells.empty()) return all;
    std::set<std::pair<int, int>> wanted;
    for (const auto& w : wells)
        wanted.insert({w.row, w.column});
    std::erase_if(all, [&](const well_index& w) { return !wanted.contains({w.row, w.column}); });
    return all;
}

operation_result<array_spec> parse_array_spec(const json& spec) {
    if (!spec.is_object())
        return make_error(operation_error_kind::invalid_value, "spec must be an object", "spec");
    if (auto known = spec_known_fields(spec, "",
                                       {"plate", "grid", "a1", "rotation_deg", "order", "wells", "dwell_ms",
                                        "advance", "ttl_pulse", "resume_from", "mode", "record"});
        !known)
        return known.error();

    array_spec s;
    const bool has_plate = spec.contains("plate"), has_grid = spec.contains("grid");
    if (has_plate == has_grid)
        return spec_error(has_plate ? "grid" : "plate", "give exactly one of plate (a preset) and grid");
    if (has_plate) {
        const auto& p = spec["plate"];
        std::string name;
        if (p.is_string())
            name = p.get<std::string>();
        else if (p.is_number_integer())
            name = std::to_string(p.get<long long>());
        auto g = plate_preset(name);
        if (!g)
            return spec_error("plate", "plate must be one of \"6\", \"12\", \"24\", \"48\", \"96\", \"384\"");
        s.plate = name;
        s.geometry = *g;
    } else {
        auto g = parse_grid(spec["grid"]);
        if (!g) return g.error();
        s.geometry = *g;
    }

    if (spec.contains("a1")) {
        const auto& a1 = spec["a1"];
        if (!(a1.is_string() && a1.get<std::string>() == "current")) {
            auto p = parse_a1(a1);
            if (!p) return p.error();
            s.a1_um = *p;
        }
    }
    if (spec.contains("rotation_deg")) {
        auto r = spec_number(spec["rotation_deg"], "rotation_deg", -360, 360);
        if (!r) return r.error();
        s.rotation_deg = *r;
    }
    if (spec.contains("order")) {
        auto o = spec_text(spec["order"], "order");
        if (!o) return o.error();
        if (*o == "raster")
            s.order = well_order::raster;
        else if (*o == "serpentine")
            s.order = well_order::serpentine;
        else
            return spec_error("order", "order must be \"raster\" or \"serpentine\"");
    }
    if (spec.contains("wells")) {
        const auto& w = spec["wells"];
        if (!w.is_array() || w.empty())
            return spec_error("wells", "wells must be a non-empty array of well names");
        std::set<std::pair<int, int>> seen;
        for (std::size_t i = 0; i < w.size(); ++i) {
            const std::string field = fmt::format("wells[{}]", i);
            auto name = spec_text(w[i], field);
            if (!name) return name.error();
            auto well = parse_well(*name, s.geometry);
            if (!well)
                return spec_error(
                    field,
                    fmt::format("{} is not a well of this {}x{} plate (A1..{})", *name, s.geometry.columns,
                                s.geometry.rows, well_name({s.geometry.rows - 1, s.geometry.columns - 1})));
            if (!seen.insert({well->row, well->column}).second)
                return spec_error(field, fmt::format("well {} is listed twice", *name));
            s.wells.push_back(*well);
        }
    }
    if (spec.contains("dwell_ms")) {
        // Whole milliseconds, as the schema says (and as RT Z= takes them).
        auto d = spec_integer(spec["dwell_ms"], "dwell_ms", 0, max_array_dwell_ms);
        if (!d) return d.error();
        s.dwell_ms = *d;
    }
    if (spec.contains("advance")) {
        auto a = spec_text(spec["advance"], "advance");
        if (!a) return a.error();
        if (*a == "timer")
            s.advance = advance_source::timer;
        else if (*a == "ttl")
            s.advance = advance_source::ttl;
        else if (*a == "next")
            s.advance = advance_source::next;
        else
            return spec_error("advance", "advance must be \"timer\", \"ttl\" or \"next\"");
    }
    if (spec.contains("ttl_pulse")) {
        if (!spec["ttl_pulse"].is_boolean())
            return spec_error("ttl_pulse", "ttl_pulse must be true or false");
        s.ttl_pulse = spec["ttl_pulse"].get<bool>();
    }
    if (spec.contains("mode")) {
        auto m = spec_text(spec["mode"], "mode");
        if (!m) return m.error();
        if (*m == "auto")
            s.mode = run_mode::automatic;
        else if (*m == "firmware")
            s.mode = run_mode::firmware;
        else if (*m == "host")
            s.mode = run_mode::host;
        else
            return spec_error("mode", "mode must be \"auto\", \"firmware\" or \"host\"");
    }
    if (spec.contains("resume_from")) {
        auto name = spec_text(spec["resume_from"], "resume_from");
        if (!name) return name.error();
        auto well = parse_well(*name, s.geometry);
        if (!well) return spec_error("resume_from", fmt::format("{} is not a well of this plate", *name));
        const auto v = s.visits();
        if (std::find(v.begin(), v.end(), *well) == v.end())
            return spec_error("resume_from", fmt::format("well {} is not among the wells to visit", *name));
        s.resume_from = *well;
    }
    return s;
}

}  // namespace gw::jobs
