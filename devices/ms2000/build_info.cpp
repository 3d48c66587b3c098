#include "devices/ms2000/build_info.hpp"

#include <algorithm>
#include <array>
#include <charconv>

#include "devices/ms2000/ascii.hpp"
#include "devices/ms2000/error.hpp"

namespace gw::devices::ms2000 {

namespace {

struct module_names {
    module m;
    std::string_view id;
    std::string_view line;                  // what format_build_x prints
    std::array<std::string_view, 3> alias;  // other spellings, compared after normalise()
};

// Lines are compared after normalise(), so "DAC_OUT" and "DAC OUT" are one spelling.
constexpr std::array<module_names, static_cast<std::size_t>(module::count_)> modules_table{{
    {module::array, "array", "ARRAY MODULE", {"", "", ""}},
    {module::ring_buffer, "ring_buffer", "RING BUFFER", {"", "", ""}},
    {module::scan, "scan", "SCAN MODULE", {"", "", ""}},
    {module::ttl_report, "ttl_report", "TTL_REPORT_INT", {"TTL REPORT", "", ""}},
    {module::serial_out, "serial_out", "SERIAL OUT", {"", "", ""}},
    {module::binary_output, "binary_output", "BINARY_OUTPUT", {"", "", ""}},
    {module::planar_correction, "planar_correction", "PLANAR CORRECTION", {"", "", ""}},
    {module::dac_out, "dac_out", "DAC OUT", {"", "", ""}},
    {module::led_dimmer, "led_dimmer", "LED DIMMER", {"DLED", "", ""}},
    {module::autofocus, "autofocus", "AUTOFOCUS", {"AFOCUS", "", ""}},
    {module::crisp, "crisp", "CRISP", {"", "", ""}},
    {module::sequencer, "sequencer", "SEQUENCER", {"", "", ""}},
    {module::tracer, "tracer", "TRACER", {"", "", ""}},
    {module::multiaxis_moves, "multiaxis_moves", "MULTIAXIS MOVES", {"", "", ""}},
    {module::search_index, "search_index", "SEARCH INDEX", {"", "", ""}},
    {module::in0_int, "in0_int", "IN0_INT", {"INO INT", "", ""}},
    {module::enc_int, "enc_int", "ENC_INT", {"ENC INT 2", "", ""}},
    {module::ll_commands, "ll_commands", "LL COMMANDS", {"", "", ""}},
}};

constexpr std::string_view motor_axes_key = "Motor Axes:";
constexpr std::string_view cmds_key = "CMDs:";
constexpr std::string_view bootloader_key = "BootLdr V:";
constexpr std::string_view hardware_key = "Hdwr REV.";
constexpr std::string_view tracer_suffix = "_TRACER";
constexpr int default_ring_buffer_size = 50;

// Upper case, '_' read as a space, runs of spaces collapsed: "ttl_report  int" -> "TTL REPORT INT".
std::string normalise(std::string_view s) {
    std::string out;
    for (char c : trim_blanks(s)) {
        if (c == '_' || c == '\t') c = ' ';
        if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
        if (c == ' ' && (out.empty() || out.back() == ' ')) continue;
        out.push_back(c);
    }
    if (!out.empty() && out.back() == ' ') out.pop_back();
    return out;
}

bool names_match(std::string_view normalised, std::string_view spelling) {
    return !spelling.empty() && normalised == normalise(spelling);
}

struct recognised {
    module m;
    int ring_size = 0;
};

std::optional<recognised> recognise(std::string_view line) {
    const std::string n = normalise(line);
    // "RING BUFFER" may carry its capacity: "RING BUFFER 250".
    constexpr std::string_view ring = "RING BUFFER";
    if (n.starts_with(ring) && (n.size() == ring.size() || n[ring.size()] == ' ')) {
        const std::string_view rest = std::string_view(n).substr(std::min(n.size(), ring.size() + 1));
        int size = 0;
        const auto [ptr, ec] = std::from_chars(rest.data(), rest.data() + rest.size(), size);
        if (ec != std::errc{} || ptr != rest.data() + rest.size() || size <= 0)
            size = default_ring_buffer_size;
        return recognised{module::ring_buffer, size};
    }
    for (const module_names& entry : modules_table) {
        if (names_match(n, entry.line)) return recognised{entry.m};
        for (std::string_view alias : entry.alias) {
            if (names_match(n, alias)) return recognised{entry.m};
        }
    }
    return std::nullopt;
}

void set(build_info& info, module m) {
    info.modules.set(static_cast<std::size_t>(m));
}

}  // namespace

std::string_view module_id(module m) {
    const auto i = static_cast<std::size_t>(m);
    return i < modules_table.size() ? modules_table[i].id : std::string_view{};
}

std::string_view module_line(module m) {
    const auto i = static_cast<std::size_t>(m);
    return i < modules_table.size() ? modules_table[i].line : std::string_view{};
}

std::optional<module> module_from_id(std::string_view id) {
    for (const module_names& entry : modules_table) {
        if (entry.id == id) return entry.m;
    }
    return std::nullopt;
}

boost::system::result<build_info> parse_build_x(std::string_view text) {
    std::vector<std::string_view> lines;
    while (!text.empty()) {
        const auto end = std::min(text.find_first_of("\r\n"), text.size());
        const std::string_view line = trim_blanks(text.substr(0, end));
        if (!line.empty()) lines.push_back(line);
        text.remove_prefix(std::min(end + 1, text.size()));
    }
    if (lines.empty()) return make_error_code(error::unrecognized_reply);

    build_info info;
    std::string_view name = lines.front();
    // Whether an MS-2000 prefixes the build name with ":A " is unknown; accept both.
    if (name.starts_with(":A ")) name = trim_blanks(name.substr(3));
    if (name.empty() || name.starts_with(":")) return make_error_code(error::unrecognized_reply);
    info.name = std::string(name);
    if (name.size() > tracer_suffix.size() && name.ends_with(tracer_suffix)) set(info, module::tracer);

    for (std::size_t i = 1; i < lines.size(); ++i) {
        const std::string_view line = lines[i];
        if (line.starts_with(motor_axes_key)) {
            info.motor_axes.clear();
            for (char c : line.substr(motor_axes_key.size())) {
                if (c != ' ' && c != '\t') info.motor_axes.push_back(c);
            }
        } else if (line.starts_with(cmds_key)) {
            info.command_axes.clear();
            for (char c : line.substr(cmds_key.size())) {
                if (c != ' ' && c != '\t') info.command_axes.push_back(c);
            }
        } else if (line.starts_with(bootloader_key)) {
            info.bootloader = std::string(trim_blanks(line.substr(bootloader_key.size())));
        } else if (line.starts_with(hardware_key)) {
            info.hardware_revision = std::string(trim_blanks(line.substr(hardware_key.size())));
        } else {
            info.module_lines.emplace_back(line);
            if (const auto r = recognise(line)) {
                set(info, r->m);
                if (r->m == module::ring_buffer) info.ring_buffer_size = r->ring_size;
            }
        }
    }
    return info;
}

std::string format_build_x(const build_info& info) {
    std::string out = info.name;
    auto add_line = [&out](std::string_view key, std::string_view value) {
        out.push_back('\r');
        out.append(key);
        out.append(value);
    };
    if (!info.motor_axes.empty()) {
        std::string spaced;
        for (char c : info.motor_axes) {
            spaced.push_back(' ');
            spaced.push_back(c);
        }
        add_line(motor_axes_key, spaced);
    }
    if (!info.command_axes.empty()) add_line(cmds_key, " " + info.command_axes);
    if (!info.bootloader.empty()) add_line(bootloader_key, info.bootloader);
    if (!info.hardware_revision.empty()) add_line(hardware_key, info.hardware_revision);

    // Modules already printed by a module line are not repeated.
    std::bitset<static_cast<std::size_t>(module::count_)> printed;
    if (info.name.size() > tracer_suffix.size() && info.name.ends_with(tracer_suffix)) {
        printed.set(static_cast<std::size_t>(module::tracer));
    }
    for (const std::string& line : info.module_lines) {
        add_line(line, {});
        if (const auto r = recognise(line)) printed.set(static_cast<std::size_t>(r->m));
    }
    for (std::size_t i = 0; i < printed.size(); ++i) {
        if (!info.modules.test(i) || printed.test(i)) continue;
        const auto m = static_cast<module>(i);
        if (m == module::ring_buffer && info.ring_buffer_size > 0 &&
            info.ring_buffer_size != default_ring_buffer_size) {
            add_line(module_line(m), " " + std::to_string(info.ring_buffer_size));
        } else {
            add_line(module_line(m), {});
        }
    }
    return out;
}

}  // namespace gw::devices::ms2000
