// Arbitrary controller output through what the driver does with it: framing, the acceptance test of
// every command the driver sends, the snapshot updates, and every JSON encoder of controller data.
// The JSON is dumped with nlohmann's strict handler, which throws on invalid UTF-8: the fuzzer fails if
// any byte a controller sent reaches an encoder unescaped. Byte 0 picks how the stream is cut.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/crisp.hpp"
#include "devices/ms2000/error_log.hpp"
#include "devices/ms2000/line_framer.hpp"
#include "devices/ms2000/reply_check.hpp"
#include "devices/ms2000/report_frame.hpp"
#include "devices/serial/controller_events.hpp"
#include "devices/serial/escape.hpp"
#include "devices/serial/snapshot_update.hpp"
#include "gateway/events/event_json.hpp"

namespace ms2000 = gw::devices::ms2000;
namespace devices = gw::devices;

namespace {

void check(bool condition) {
    if (!condition) std::abort();
}

void strict_dump(const nlohmann::json& j) {
    (void)j.dump();  // throws type_error.316 on invalid UTF-8: an uncaught exception is a finding
}

// The driver's own commands (identification, polling, resynchronisation) and a few a user may type.
const std::vector<ms2000::command>& commands() {
    static const std::vector<ms2000::command> list = [] {
        std::vector<ms2000::command> c{ms2000::version(),
                                       ms2000::build_x(),
                                       ms2000::query("CNTS", "XYZ"),
                                       ms2000::query("SL", "XYZ"),
                                       ms2000::query("SU", "XYZ"),
                                       ms2000::query("TTL", "XY"),
                                       ms2000::where("XYZ"),
                                       ms2000::status(),
                                       ms2000::query("RS", "X"),
                                       ms2000::who(),
                                       ms2000::halt(),
                                       ms2000::save_settings(),
                                       ms2000::read_error_log(),
                                       ms2000::crisp_state_query(),
                                       ms2000::crisp_offset_query()};
        for (const char* line : {"INFO X", "RM X?", "LED X?", "BU"})
            c.push_back(ms2000::raw_command(line).value());
        for (const auto verb : devices::motion_setting_verbs)  // from index 19 on
            c.push_back(ms2000::query(verb, "XYZ"));
        return c;
    }();
    return list;
}

void apply(devices::controller_snapshot& s, std::size_t index, const ms2000::reply& r) {
    switch (index) {
        case 0:
            devices::apply_version(s, r);
            break;
        case 1:
            devices::apply_build(s, &r);
            break;
        case 2:
            devices::apply_axis_numbers(s, r, &devices::axis_state::counts_per_mm);
            break;
        case 3:
            devices::apply_axis_numbers(s, r, &devices::axis_state::lower_limit_mm);
            break;
        case 4:
            devices::apply_axis_numbers(s, r, &devices::axis_state::upper_limit_mm);
            break;
        case 5:
            devices::apply_ttl_modes(s, r);
            break;
        case 6:
            devices::apply_where(s, r);
            break;
        case 8:
            devices::apply_axis_busy(s, 0, r);
            break;
        case 12:
            if (const auto codes = ms2000::error_log_codes(r)) {
                s.error_log_recent = *codes;
                strict_dump(gw::error_log_json(devices::error_log_event{"fuzz", *codes, {}}));
            }
            break;
        case 13:
            s.crisp_state = ms2000::crisp_state_of(r);
            if (s.crisp_state) check(!ms2000::crisp_state_name(*s.crisp_state).empty());
            strict_dump(gw::state_json(s));
            break;
        case 14:
            if (const auto v = ms2000::single_reading(r)) check(std::isfinite(*v));
            break;
        default:
            if (index >= 19) {
                devices::apply_motion_setting(s, devices::motion_setting_verbs[index - 19], r);
                for (const auto& a : s.axes)
                    check(a.finish_error_printed_step_mm >= 0 && a.finish_error_printed_step_mm <= 0.5);
            }
            break;
    }
}

void on_line(devices::controller_snapshot& s, const std::string& line) {
    const auto& list = commands();
    for (std::size_t i = 0; i < list.size(); ++i) {
        const auto r = ms2000::accept_reply(list[i], line);
        if (!r) {
            // What the driver hands out for a refused line: the escaped text.
            const std::string shown = devices::escape_control(line);
            check(ms2000::is_reply_text(shown));
            strict_dump(nlohmann::json{{"raw_reply", shown}});
            continue;
        }
        check(ms2000::is_reply_text(r->raw));
        check(ms2000::reply_fits(list[i].form, *r));
        strict_dump(gw::reply_json(*r));
        apply(s, i, *r);
    }
    if (!ms2000::is_reply_text(line)) return;
    if (const auto report = ms2000::parse_position_report(line)) {
        devices::ttl_event e;
        e.controller_id = "fuzz";
        e.controller_ms = report->milliseconds;
        for (double p : report->positions)
            e.axes.push_back({'X', p / 10.0});
        strict_dump(gw::ttl_json(e));
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    const std::size_t chunk = 1 + data[0] % 64;
    const std::string_view stream(reinterpret_cast<const char*>(data + 1), size - 1);

    devices::controller_snapshot s;
    s.id = "fuzz";
    ms2000::line_framer framer(512);
    std::vector<std::string> lines;
    for (std::size_t at = 0; at < stream.size(); at += chunk) {
        lines.clear();
        (void)framer.feed(stream.substr(at, chunk), lines);
        for (const auto& line : lines)
            on_line(s, line);
    }
    strict_dump(gw::state_json(s));
    strict_dump(gw::position_json(s));

    // The same bytes on a report port.
    ms2000::report_decoder decoder(ms2000::report_format::binary, 3);
    std::vector<ms2000::report_frame> frames;
    decoder.feed(std::span(data + 1, size - 1), frames);
    for (const auto& frame : frames) {
        devices::report_event e;
        e.controller_id = "fuzz";
        for (const auto& count : frame.axes)
            e.axes.push_back({count.axis, count.count, count.count / 10000.0});
        // Written by hand: whatever the frame holds, the text must be one valid JSON value.
        const auto text = gw::report_json_text(e);
        if (!nlohmann::json::accept(text)) __builtin_trap();
    }
    return 0;
}
