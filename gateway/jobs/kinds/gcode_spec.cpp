#include "gateway/jobs/kinds/gcode_spec.hpp"

#include <charconv>
#include <fmt/format.h>

#include "gateway/common/json_keys.hpp"
#include "gateway/jobs/kinds/spec_fields.hpp"

namespace gw::jobs {

namespace {

using json = nlohmann::json;

operation_error bad(const std::string& field, std::string message) {
    return spec_error(field, std::move(message));
}

// An option value as set_option() reads it: numbers in their shortest exact form, strings as given.
std::optional<std::string> option_text(const json& v) {
    if (v.is_string()) return v.get<std::string>();
    if (v.is_number_integer()) return std::to_string(v.get<long long>());
    if (v.is_number()) return fmt::format("{}", v.get<double>());
    return std::nullopt;
}

}  // namespace

operation_result<gcode_spec> parse_gcode_spec(const json& spec) {
    if (!spec.is_object())
        return make_error(operation_error_kind::invalid_value, "spec must be an object", "spec");
    if (const auto key = first_unknown_key(spec, {"program", "file", "options", "record"}))
        return bad(*key, "unknown field " + *key + " (program, file, options, record)");
    gcode_spec out;
    if (spec.contains("program") == spec.contains("file"))
        return bad(spec.contains("file") ? "file" : "program", "give exactly one of program and file");
    if (spec.contains("program")) {
        const auto& p = spec["program"];
        if (!p.is_string()) return bad("program", "program must be a string (the G-code text)");
        const auto& text = p.get_ref<const std::string&>();
        if (text.size() > max_inline_gcode_bytes)
            return bad("program", fmt::format("program is {} bytes; above {} bytes, upload it and give its "
                                              "\"file\" id",
                                              text.size(), max_inline_gcode_bytes));
        out.program = text;
    } else {
        const auto& f = spec["file"];
        if (!f.is_string() || f.get_ref<const std::string&>().empty())
            return bad("file", "file must be the id of an uploaded program (\"g-...\")");
        out.file = f.get<std::string>();
    }
    if (spec.contains("options")) {
        const auto& o = spec["options"];
        if (!o.is_object()) return bad("options", "options must be an object {\"name\": value}");
        for (const auto& [name, value] : o.items()) {
            const auto text = option_text(value);
            if (!text) return bad("options." + name, "options." + name + " must be a number or a string");
            if (auto why = gcode::set_option(out.options, name, *text)) return bad("options." + name, *why);
        }
        if (auto why = gcode::validate(out.options)) {
            // "arc_tolerance_mm must be >= 1e-7": point at the option when the message names one given.
            const auto name = why->substr(0, why->find(' '));
            return bad(o.contains(name) ? "options." + name : "options", *why);
        }
    }
    return out;
}

std::string gcode_source_field(const gcode_spec& spec) {
    return spec.file ? "spec.file" : "spec.program";
}

std::string gcode_step_name(int first_line, int last_line) {
    return first_line == last_line ? fmt::format("line {}", last_line)
                                   : fmt::format("lines {}-{}", first_line, last_line);
}

std::optional<int> gcode_step_last_line(std::string_view name) {
    std::string_view digits;
    if (name.starts_with("line ")) {
        digits = name.substr(5);
    } else if (name.starts_with("lines ")) {
        const auto dash = name.find('-');
        if (dash == std::string_view::npos) return std::nullopt;
        digits = name.substr(dash + 1);
    } else {
        return std::nullopt;
    }
    int line = 0;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), line);
    if (ec != std::errc{} || end != digits.data() + digits.size() || line <= 0) return std::nullopt;
    return line;
}

}  // namespace gw::jobs
