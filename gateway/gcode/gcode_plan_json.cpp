#include "gateway/gcode/gcode_plan_json.hpp"

#include <cmath>
#include <cstdio>
#include <string>

namespace gw::gcode {

namespace {

void write_point(std::ostream& out, const vec3& p) {
    out << '[' << json_number(p.x) << ',' << json_number(p.y) << ',' << json_number(p.z) << ']';
}

}  // namespace

std::string json_number(double v) {
    if (!std::isfinite(v)) return "null";
    return trimmed_fixed(v, 6);
}

std::string trimmed_fixed(double v, int decimals) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
    std::string s(buf);
    if (s.find('.') != std::string::npos) {  // trailing zeros of the fraction only
        while (s.back() == '0')
            s.pop_back();
        if (s.back() == '.') s.pop_back();
    }
    if (s == "-0") s = "0";
    return s;
}

std::string json_string(std::string_view text) {
    std::string out;
    out.reserve(text.size() + 2);
    out.push_back('"');
    for (const char c : text) {
        const auto u = static_cast<unsigned char>(c);
        if (c == '"' || c == '\\') {
            out.push_back('\\');
            out.push_back(c);
        } else if (u < 0x20 || u >= 0x7f) {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(u));
            out += buf;
        } else {
            out.push_back(c);
        }
    }
    out.push_back('"');
    return out;
}

plan_json_writer::plan_json_writer(std::ostream& out) : out_(out) {
    out_ << "{\"units\":\"mm\",\"moves\":[";
}

void plan_json_writer::on_move(const planned_move& m) {
    if (!first_) out_ << ',';
    first_ = false;
    out_ << "{\"line\":" << m.line << ",\"kind\":\"" << to_string(m.kind) << '"';
    switch (m.kind) {
        case move_kind::rapid:
        case move_kind::linear:
            out_ << ",\"end\":";
            write_point(out_, m.end);
            out_ << ",\"feed_mm_s\":" << json_number(m.feed_mm_s);
            break;
        case move_kind::arc:
            out_ << ",\"end\":";
            write_point(out_, m.end);
            out_ << ",\"center\":";
            write_point(out_, m.arc.center);
            out_ << ",\"plane\":\"" << to_string(m.arc.plane) << "\",\"direction\":\""
                 << to_string(m.arc.direction) << "\",\"feed_mm_s\":" << json_number(m.feed_mm_s);
            break;
        case move_kind::dwell:
            out_ << ",\"dwell_ms\":" << json_number(m.dwell_ms);
            break;
        case move_kind::ttl:
            out_ << ",\"ttl\":\"" << (m.ttl_on ? "on" : "off") << '"';
            break;
        case move_kind::analog:
            out_ << ",\"analog_v\":" << json_number(m.analog_v);
            break;
    }
    out_ << '}';
}

void plan_json_writer::finish(const plan_summary& s) {
    out_ << "],\"segments\":" << s.segments << ",\"estimated_s\":" << json_number(s.estimated_s)
         << ",\"bounds\":{\"min\":";
    write_point(out_, s.min);
    out_ << ",\"max\":";
    write_point(out_, s.max);
    out_ << "},\"warnings\":[";
    for (std::size_t i = 0; i < s.warnings.size(); ++i)
        out_ << (i > 0 ? "," : "") << json_string(s.warnings[i]);
    out_ << "]}";
}

void write_error_json(std::ostream& out, const gcode_error& e) {
    out << "{\"error\":{\"line\":" << e.line << ",\"column\":" << e.column
        << ",\"message\":" << json_string(e.message) << "}}";
}

bool write_plan_json(std::istream& in, const gcode_options& options, std::ostream& out) {
    const auto start = in.tellg();
    if (start != std::istream::pos_type(-1)) {
        auto checked = check_program(in, options);
        if (const auto* e = std::get_if<gcode_error>(&checked)) {
            write_error_json(out, *e);
            return false;
        }
        in.clear();
        in.seekg(start);
    }
    plan_json_writer writer(out);
    auto result = plan_program(in, options, writer);
    if (const auto* e = std::get_if<gcode_error>(&result)) {
        // Only reached for a stream that cannot seek: the document so far is abandoned.
        out << "\n";
        write_error_json(out, *e);
        return false;
    }
    writer.finish(std::get<plan_summary>(result));
    return true;
}

}  // namespace gw::gcode
