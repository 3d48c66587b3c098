// The G-code translator on arbitrary bytes: lexing every line, then planning the whole program with
// the options picked by the first byte. Checks: errors carry a place and an ASCII message, planned
// moves are finite, arc segments end at the move's end, the summary's bounds hold every end point,
// and the plan JSON writer completes.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>
#include <string_view>
#include <variant>

#include "gateway/gcode/gcode_lexer.hpp"
#include "gateway/gcode/gcode_plan_json.hpp"
#include "gateway/gcode/gcode_planner.hpp"

namespace gcode = gw::gcode;

namespace {

void check(bool condition) {
    if (!condition) std::abort();
}

bool finite(const gcode::vec3& p) {
    return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

void check_error(const gcode::gcode_error& e) {
    check(e.line >= 0 && e.column >= 0 && !e.message.empty());
    for (const char c : e.message)
        check(static_cast<unsigned char>(c) >= 0x20 && static_cast<unsigned char>(c) < 0x7f);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    const std::uint8_t flags = data[0];
    const std::string program(reinterpret_cast<const char*>(data + 1), size - 1);

    gcode::gcode_options options;
    if ((flags & 1) != 0) options.decimal_point = gcode::decimal_point_reading::least_increment;
    if ((flags & 2) != 0) options.z = gcode::z_mode::analog;
    if ((flags & 4) != 0) options.xyz_scale = 0.01;
    if ((flags & 8) != 0) options.arc_tolerance_mm = 0.1;  // fewer segments: keeps runs fast
    if ((flags & 16) != 0) {
        options.analog_low_um = -10;
        options.analog_high_um = 30;
    }
    if ((flags & 32) != 0) options.analog_range = gcode::analog_range_policy::error;
    options.max_line_chars = 256;

    // Every line on its own.
    gcode::gcode_block block;
    std::size_t start = 0;
    int line = 0;
    while (start <= program.size() && line < 64) {
        std::size_t end = program.find('\n', start);
        if (end == std::string::npos) end = program.size();
        ++line;
        if (const auto e =
                gcode::lex_line(std::string_view(program).substr(start, end - start), line, block)) {
            check_error(*e);
            check(e->line == line);
        }
        start = end + 1;
    }

    // The whole program.
    std::istringstream in(program);
    gcode::gcode_planner planner(in, options);
    std::uint64_t segments = 0;
    while (const gcode::planned_move* m = planner.next()) {
        check(finite(m->start) && finite(m->end) && m->line >= 1);
        check(std::isfinite(m->estimated_s) && m->estimated_s >= 0);
        if (m->kind == gcode::move_kind::arc) {
            check(m->segments >= 1);
            check(gcode::segment_end(*m, m->segments) == m->end);
            check(std::abs(m->arc.sweep) <= 2 * 3.141592653589794);
            if (m->segments <= 64) {
                for (std::uint64_t i = 1; i < m->segments; ++i)
                    check(finite(gcode::segment_end(*m, i)));
            }
        }
        if (m->kind == gcode::move_kind::analog) check(m->analog_v >= 0 && m->analog_v <= 10);
        segments += m->kind == gcode::move_kind::rapid || m->kind == gcode::move_kind::linear ||
                            m->kind == gcode::move_kind::arc
                        ? m->segments
                        : 0;
        const auto s = planner.summary();
        check(s.min.x <= m->end.x && m->end.x <= s.max.x);
        check(s.min.y <= m->end.y && m->end.y <= s.max.y);
        check(s.min.z <= m->end.z && m->end.z <= s.max.z);
        if (segments > 2'000'000) return 0;  // huge arcs: valid but slow; the rest is covered
    }
    if (planner.error()) {
        check_error(*planner.error());
    } else {
        check(planner.summary().segments == segments);
    }

    std::istringstream again(program);
    std::ostringstream json;
    const bool ok = gcode::write_plan_json(again, options, json);
    check(ok == !planner.error().has_value());
    check(!json.str().empty() && json.str().front() == '{' && json.str().back() == '}');
    return 0;
}
