#include "gateway/gcode/gcode_plan_summary_json.hpp"

#include <variant>

#include "gateway/gcode/gcode_plan_json.hpp"

namespace gw::gcode {

namespace {

void write_point(std::ostream& out, const vec3& p) {
    out << '[' << json_number(p.x) << ',' << json_number(p.y) << ',' << json_number(p.z) << ']';
}

}  // namespace

void write_plan_summary_json(std::ostream& out, const plan_summary& s) {
    out << "{\"units\":\"mm\",\"move_count\":" << s.moves << ",\"lines\":" << s.lines
        << ",\"segments\":" << s.segments << ",\"estimated_s\":" << json_number(s.estimated_s)
        << ",\"bounds\":{\"min\":";
    write_point(out, s.min);
    out << ",\"max\":";
    write_point(out, s.max);
    out << "},\"warnings\":[";
    for (std::size_t i = 0; i < s.warnings.size(); ++i)
        out << (i > 0 ? "," : "") << json_string(s.warnings[i]);
    out << "]}";
}

bool write_plan_summary_json(std::istream& in, const gcode_options& options, std::ostream& out) {
    auto checked = check_program(in, options);
    if (const auto* e = std::get_if<gcode_error>(&checked)) {
        write_error_json(out, *e);
        return false;
    }
    write_plan_summary_json(out, std::get<plan_summary>(checked));
    return true;
}

}  // namespace gw::gcode
