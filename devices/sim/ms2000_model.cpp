#include "devices/sim/ms2000_model.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>

#include <nlohmann/json.hpp>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/error.hpp"
#include "devices/ms2000/motion_profile.hpp"
#include "devices/ms2000/report_frame.hpp"
#include "devices/sim/letter_parameters.hpp"

namespace gw::devices::sim {

namespace {

using ms2000::module;
using op = line_argument::op;

std::string fixed(double value, int decimals) {
    std::array<char, 64> buffer{};
    const auto [end, ec] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value,
                                         std::chars_format::fixed, decimals);
    if (ec != std::errc{}) return "0";
    std::string text(buffer.data(), end);
    if (text.size() > 1 && text.front() == '-' && text.find_first_not_of("-0.") == std::string::npos)
        text.erase(0, 1);  // "-0.0" -> "0.0"
    return text;
}

std::string trimmed(double value, int decimals) {
    return ms2000::format_number(value, decimals);
}

sim_time ms(double milliseconds) {
    return sim_time{static_cast<long long>(std::llround(milliseconds * 1000.0))};
}

// Which module a verb needs; commands of modules absent from the build answer ":N-1" (doc §2.2).
std::optional<module> required_module(std::string_view verb) {
    if (verb == "LOAD") return module::ring_buffer;
    if (verb == "ARRAY" || verb == "AHOME" || verb == "AIJ") return module::array;
    if (verb == "SCAN" || verb == "SCANR" || verb == "SCANV") return module::scan;
    if (verb == "WRDAC") return module::dac_out;
    if (verb == "LED") return module::led_dimmer;
    if (verb == "CUSTOMB") return module::planar_correction;
    if (verb == "LOCK" || verb == "EXTRA" || verb == "LR" || verb == "AL" || verb == "UL")
        return module::crisp;
    if (verb == "AFOCUS" || verb == "AFLIM" || verb == "AFSET" || verb == "AFMOVE" || verb == "AFADJ")
        return module::autofocus;
    return std::nullopt;
}

enum class shape { a, colon };

// Per-axis settings answered as ":A X=.." (shape::a) or ":X=.. A" (shape::colon), doc §2.6.
struct param_row {
    std::string_view verb;
    shape reply;
    int decimals;
    bool fixed_decimals;  // "%f"-like (SPEED "5.745920") rather than trailing zeros dropped
    double min, max;      // out of range -> ":N-4" (SPEED clamps instead)
};

constexpr std::array<param_row, 21> param_rows{{
    {"SPEED", shape::a, 6, true, 0, 1e12},       {"ACCEL", shape::colon, 0, false, 1, 10000},
    {"BACKLASH", shape::colon, 6, false, 0, 10}, {"PCROS", shape::a, 6, false, 0, 10},
    {"ERROR", shape::colon, 6, false, 0, 100},   {"WAIT", shape::colon, 0, false, 0, 250},
    {"OVERSHOOT", shape::a, 6, false, 0, 10},    {"KP", shape::a, 0, false, 0, 10000},
    {"KI", shape::a, 0, false, 0, 10000},        {"KD", shape::a, 0, false, 0, 10000},
    {"AALIGN", shape::a, 0, false, 0, 99},       {"SETUP", shape::a, 6, false, -1e6, 1e6},
    {"SETLOW", shape::a, 6, false, -1e6, 1e6},   {"UM", shape::a, 4, false, -1e9, 1e9},
    {"CNTS", shape::a, 4, false, 0, 1e9},        {"Z2B", shape::a, 0, false, 0, 15},
    {"JSSPD", shape::a, 0, false, -100, 100},    {"LR", shape::a, 3, false, -1e6, 1e6},
    {"AL", shape::a, 3, false, -1e6, 1e6},       {"UL", shape::a, 0, false, -1e6, 1e6},
    {"KV", shape::a, 0, false, 0, 10000},
}};

// INFO's name of a JOYSTICK input code.
std::string input_device_name(double code) {
    switch (static_cast<int>(code)) {
        case 0:
            return "NONE";
        case 2:
            return "JS_X";
        case 3:
            return "JS_Y";
        case 22:
            return "Z_WHEEL";
        default:
            return std::to_string(static_cast<int>(code));
    }
}

const param_row* find_param(std::string_view verb) {
    for (const auto& row : param_rows)
        if (row.verb == verb) return &row;
    return nullptr;
}

}  // namespace

ms2000_model::ms2000_model(sim_config config)
    : config_(std::move(config)),
      build_(make_build_info(config_)),
      screw_(lead_screw_for(config_.lead_screw).value()) {
    int index = 0;
    for (const char c : config_.motor_axes) {
        axis a;
        a.letter = c;
        a.params = {{"SPEED", screw_.default_speed_mm_s},
                    {"ACCEL", 20},
                    {"BACKLASH", 0},
                    {"PCROS", screw_.encoder_nm / 1e6},
                    {"ERROR", 0.0004},
                    {"WAIT", 0},
                    {"OVERSHOOT", 0},
                    {"KP", 60},
                    {"KI", 10},
                    {"KD", 0},
                    {"KV", 15},
                    {"AALIGN", 85},
                    {"SETUP", 110},
                    {"SETLOW", -110},
                    {"UM", 10000},
                    {"CNTS", screw_.counts_per_mm},
                    {"Z2B", index},
                    {"JSSPD", 100},
                    {"LR", 0},
                    {"AL", 0},
                    {"UL", 0},
                    {"SETHOME", 1000},
                    {"MOTCTRL", 1},
                    {"VECTOR", 0},
                    // The input that drives the axis (TASI's JoystickInput codes): the joystick's X
                    // and Y for the first two axes, the knob for the third.
                    {"JOYSTICK", index == 0   ? 2
                                 : index == 1 ? 3
                                 : index == 2 ? 22
                                              : 0}};
        axes_.push_back(std::move(a));
        ++index;
    }
    for (const char c : std::string_view("XYZF"))
        led_[c] = 0;
}

// ---------------------------------------------------------------------------------------------
// Reply shapes

std::string ms2000_model::ack() const {
    return config_.ack_trailing_space ? ":A \r\n" : ":A\r\n";
}

std::string ms2000_model::values(const std::vector<std::string>& items) const {
    std::string out = ":A";
    for (const auto& v : items)
        out += " " + v;
    if (config_.value_trailing_space) out += ' ';
    return out + "\r\n";
}

std::string ms2000_model::axes_a(const std::vector<std::pair<char, std::string>>& items) const {
    std::string out = ":A";
    for (const auto& [c, v] : items)
        out += std::string(" ") + c + "=" + v;
    if (config_.value_trailing_space) out += ' ';
    return out + "\r\n";
}

std::string ms2000_model::axes_colon(const std::vector<std::pair<char, std::string>>& items) const {
    std::string out = ":";
    for (const auto& [c, v] : items)
        out += std::string(1, c) + "=" + v + " ";
    return out + "A\r\n";
}

std::string ms2000_model::axes_led(const std::vector<std::pair<char, std::string>>& items) const {
    std::string out;
    for (const auto& [c, v] : items)
        out += std::string(1, c) + "=" + v + " ";
    return out + ":A\r\n";
}

std::string ms2000_model::error(int code) {
    return ":N" + std::to_string(code) + "\r\n";
}

// ---------------------------------------------------------------------------------------------
// Framing

std::string ms2000_model::feed(std::string_view bytes, sim_time now) {
    std::string out;
    for (const char ch : bytes) {
        const auto byte = static_cast<unsigned char>(ch);
        if (low_level_pending_) {  // second byte of a 0xFF setup command: swallowed
            low_level_pending_ = false;
            continue;
        }
        if (halted_fast_) {  // the CR after a fast-path HALT belongs to it
            halted_fast_ = false;
            if (byte == '\r') continue;
        }
        // "\" at the start of a line is HALT at once, CR or not: the parser's fast path (doc §1).
        // mesoSPIM sends the backslash without a CR and waits for the answer.
        if (byte == '\\' && line_.empty()) {
            out += handle_line("\\", now);
            halted_fast_ = true;
            continue;
        }
        switch (byte) {
            case 0xFF:
                low_level_pending_ = true;
                break;
            case '\r':
                out += handle_line(line_, now);
                line_.clear();
                break;
            case '\n':
            case 0x11:  // XON
            case 0x13:  // XOFF
                break;
            case 0x7F:  // DEL and BS: "abort current command and flush input buffer"
            case 0x08:
                line_.clear();
                break;
            default:
                if (line_.size() < max_line_bytes) line_.push_back(ch);
        }
    }
    return out;
}

void ms2000_model::refuse_next(std::string_view verb, int code) {
    auto parsed = parse_command_line(verb);  // "M" -> "MOVE"
    refuse_next_ = {parsed ? parsed->verb : std::string(verb), code};
}

std::string ms2000_model::handle_line(std::string_view line, sim_time now) {
    advance(now);
    auto parsed = parse_command_line(line);
    if (!parsed) {
        if (parsed.error() == boost::system::errc::no_message)
            return config_.empty_line == empty_line_reply::ignore ? std::string{}
                                                                  : error(ms2000::unknown_command);
        return error(ms2000::undefined_error);
    }
    if (const auto needed = required_module(parsed->verb); needed && !has_module(config_, *needed))
        return error(ms2000::unknown_command);
    if (refuse_next_ && refuse_next_->first == parsed->verb) {
        const int code = refuse_next_->second;
        refuse_next_.reset();
        return error(code);
    }
    return dispatch(*parsed, now);
}

std::string ms2000_model::dispatch(const command_line& cmd, sim_time now) {
    const auto& v = cmd.verb;
    if (v == "STATUS") return commanded_busy(now) ? "B\r\n" : "N\r\n";
    if (v == "HALT") {
        // A SPIN or VECTOR motion is stopped without :N-21 (doc §3.2); a commanded move is not.
        const bool move_running = std::any_of(axes_.begin(), axes_.end(), [now](const axis& a) {
            return a.commanded && a.motion.busy(now) && a.motion.velocity_mm_s() == 0;
        });
        const bool was_moving = move_running || array_.self_scan || scan_.running || ring_.autoplay;
        stop_all(now);
        return was_moving ? error(ms2000::halted) : ack();
    }
    if (v == "MOVE") return cmd_move(cmd, now, false);
    if (v == "MOVREL") return cmd_move(cmd, now, true);
    if (v == "WHERE") return cmd_where(cmd, now);
    if (v == "HERE") return cmd_here(cmd, now);
    if (v == "ZERO") {
        // Zeroes every axis where it stands (a running move ends there).
        for (auto& a : axes_)
            a.motion = axis_motion(0, 0, 1, 0, 0, now);
        return ack();
    }
    if (v == "HOME") return cmd_home(cmd, now);
    if (v == "SETHOME") return cmd_sethome(cmd, now);
    if (v == "RDSTAT") return cmd_rdstat(cmd, now);
    if (v == "RDSBYTE") return cmd_rdsbyte(cmd, now);
    if (find_param(v)) return cmd_axis_param(cmd, now);
    if (v == "BUILD") return cmd_build(cmd);
    if (v == "VERSION") {
        if (cmd.find('T')) return values({"v" + config_.version});
        return ":A Version: USB-" + config_.version + " \r\n";
    }
    if (v == "WHO") return ":A ASI-MS2000 " + config_.build_name + " \r\n";
    if (v == "CDATE") return values({"Jan 15 2024 10:30:00"});
    if (v == "INFO") return cmd_info(cmd, now);
    if (v == "DUMP") return cmd_dump(cmd);
    if (v == "SAVESET") return cmd_saveset(cmd, now);
    if (v == "RTIME") return cmd_rtime(cmd, now);
    if (v == "TTL") return cmd_ttl(cmd);
    if (v == "RDADC") {
        std::vector<std::string> vals;
        for (std::size_t i = 0; i < std::max<std::size_t>(cmd.args.size(), 1); ++i)
            vals.emplace_back("128");
        return values(vals);
    }
    if (v == "MOTCTRL") {
        for (const auto& arg : cmd.args) {
            auto* a = find_axis(arg.letter);
            if (!a) return error(ms2000::unrecognized_axis);
            if (arg.kind == op::query) return values({a->params["MOTCTRL"] != 0 ? "1" : "0"});
            a->params["MOTCTRL"] = arg.kind == op::minus ? 0 : 1;
        }
        return ack();
    }
    if (v == "SPIN" || v == "VECTOR") return cmd_velocity(cmd, now);
    if (v == "JOYSTICK") return cmd_joystick(cmd);
    if (v == "AZERO" || v == "CUSTOMA" || v == "VB" || v == "SAVEPOS" || v == "UNITS" || v == "RESET") {
        if (v == "RESET") {
            // Power-up state: positions, settings and buffers as after switching on.
            auto config = config_;
            *this = ms2000_model(std::move(config));
        }
        return ack();
    }
    if (v == "ZS") return cmd_zstack(cmd, now);
    if (v == "LOAD") return cmd_load(cmd, now);
    if (v == "RBMODE") return cmd_rbmode(cmd, now);
    if (v == "ARRAY") return cmd_array(cmd, now);
    if (v == "AHOME") return cmd_ahome(cmd, now);
    if (v == "AIJ") return cmd_aij(cmd, now);
    if (v == "SCANR") return cmd_scanr(cmd);
    if (v == "SCANV") return cmd_scanv(cmd);
    if (v == "SCAN") return cmd_scan(cmd, now);
    if (v == "WRDAC") return cmd_wrdac(cmd);
    if (v == "LED") return cmd_led(cmd);
    if (v == "CUSTOMB") return cmd_customb(cmd, now);
    if (v == "LOCK") return cmd_lock(cmd, now);
    if (v == "EXTRA") return cmd_extra(cmd, now);
    if (v == "AFOCUS") return cmd_afocus(cmd, now);
    return error(ms2000::unknown_command);
}

// ---------------------------------------------------------------------------------------------
// Axes and motion

ms2000_model::axis* ms2000_model::find_axis(char letter) {
    for (auto& a : axes_)
        if (a.letter == letter) return &a;
    return nullptr;
}

const ms2000_model::axis* ms2000_model::find_axis(char letter) const {
    for (const auto& a : axes_)
        if (a.letter == letter) return &a;
    return nullptr;
}

double ms2000_model::units_per_mm(const axis& a) const {
    const auto it = a.params.find("UM");
    return it == a.params.end() || it->second == 0 ? 10000 : it->second;
}

void ms2000_model::log_error(int code) {
    errors_.push_back(code);
    if (errors_.size() > 64) errors_.erase(errors_.begin());
}

void ms2000_model::start_move(axis& a, double target_mm, sim_time now, bool commanded,
                              double speed_override) {
    const double upper = upper_stop(a), lower = lower_stop(a);
    if (target_mm > upper) {
        target_mm = upper;
        log_error(34);
    } else if (target_mm < lower) {
        target_mm = lower;
        log_error(35);
    }
    start_move_between(a, target_mm, lower, upper, now, commanded, speed_override);
}

void ms2000_model::start_move_between(axis& a, double target_mm, double lower_mm, double upper_mm,
                                      sim_time now, bool commanded, double speed_override) {
    // Targets are quantised to encoder counts (doc §3.1, MOVREL); the room for the approach leg is
    // measured from the target asked for, so that rounding inside a count adds no leg.
    const double asked_mm = target_mm;
    const double counts = screw_.counts_per_mm;
    target_mm = std::round(target_mm * counts) / counts;
    const double from = a.motion.position_mm(now);
    const double speed = speed_override > 0 ? speed_override : a.params["SPEED"];
    // A wider finish error (PC) lets the servo stop hunting sooner (seed: "Opening up the Finish
    // Error to about 10 rotary encoder counts allows the move to complete quickly").
    const double default_pc = screw_.encoder_nm / 1e6;
    const double pc = std::max(a.params["PCROS"], 1e-9);
    const double settle = ms2000::settle_ms(screw_.settle_ms, default_pc, pc);
    // Point-to-point moves approach their target past it with BACKLASH / OVERSHOOT, as far as the
    // travel allows; moves at a given speed (scan lines, retraces) do not.
    const double distance = target_mm - from;
    const double leg =
        speed_override > 0
            ? 0
            : ms2000::approach_leg_within_mm(
                  distance, ms2000::approach_leg_mm(distance, a.params["BACKLASH"], a.params["OVERSHOOT"]),
                  asked_mm, lower_mm, upper_mm);
    a.motion = axis_motion(from, target_mm, speed, a.params["ACCEL"], settle, now, leg);
    a.commanded = commanded;
}

void ms2000_model::stop_all(sim_time now) {
    for (auto& a : axes_)
        a.motion.stop(now);
    array_.self_scan = false;
    array_.next_step.reset();
    if (array_.state != 'I' && array_.state != 'C') array_.state = 'I';
    scan_.running = false;
    autofocus_done_at_.reset();  // a focus scan is a Z motion: HALT ends it
    ring_.autoplay = false;
    ring_.waiting_arrival = false;
    ring_.next_step.reset();
}

bool ms2000_model::commanded_busy(sim_time now) const {
    return std::any_of(axes_.begin(), axes_.end(),
                       [now](const axis& a) { return a.commanded && a.motion.busy(now); });
}

bool ms2000_model::busy(sim_time now) const {
    return commanded_busy(now);
}

sim_time ms2000_model::motion_done_at() const {
    sim_time t{0};
    for (const auto& a : axes_)
        t = std::max(t, a.motion.settled());
    return t;
}

double ms2000_model::position_mm(char axis_letter, sim_time now) const {
    const auto* a = find_axis(axis_letter);
    return a ? a->motion.position_mm(now) : 0;
}

double ms2000_model::position_units(char axis_letter, sim_time now) const {
    const auto* a = find_axis(axis_letter);
    return a ? a->motion.position_mm(now) * units_per_mm(*a) : 0;
}

std::string ms2000_model::cmd_move(const command_line& cmd, sim_time now, bool relative) {
    if (cmd.args.empty()) return error(ms2000::missing_parameters);
    for (const auto& arg : cmd.args) {
        if (!find_axis(arg.letter)) return error(ms2000::unrecognized_axis);
        if (arg.kind != op::set && arg.kind != op::bare) return error(ms2000::undefined_error);
    }
    for (const auto& arg : cmd.args) {
        auto& a = *find_axis(arg.letter);
        const double delta_mm = arg.value / units_per_mm(a);
        // MOVREL is relative to the current target, not the current position (doc §3.1).
        const double target = relative ? a.motion.target_mm() + delta_mm : delta_mm;
        if (relative) a.last_relative_mm = delta_mm;
        start_move(a, target, now);
    }
    return ack();
}

std::string ms2000_model::cmd_where(const command_line& cmd, sim_time now) {
    std::vector<bool> wanted(axes_.size(), cmd.args.empty());
    for (const auto& arg : cmd.args) {
        const auto it =
            std::find_if(axes_.begin(), axes_.end(), [&](const axis& a) { return a.letter == arg.letter; });
        if (it == axes_.end()) return error(ms2000::unrecognized_axis);
        wanted[static_cast<std::size_t>(it - axes_.begin())] = true;
    }
    std::vector<std::string> vals;
    for (std::size_t i = 0; i < axes_.size(); ++i)  // hardware order, not request order (doc §2.5)
        if (wanted[i]) vals.push_back(fixed(position_units(axes_[i].letter, now), config_.where_decimals));
    return values(vals);
}

std::string ms2000_model::cmd_here(const command_line& cmd, sim_time now) {
    if (cmd.args.empty()) return error(ms2000::missing_parameters);
    for (const auto& arg : cmd.args)
        if (!find_axis(arg.letter)) return error(ms2000::unrecognized_axis);
    for (const auto& arg : cmd.args) {
        auto& a = *find_axis(arg.letter);
        const double mm = arg.value / units_per_mm(a);
        a.motion = axis_motion(mm, mm, 1, 0, 0, now);
        a.motion.stop(now);
    }
    return ack();
}

std::string ms2000_model::cmd_home(const command_line& cmd, sim_time now) {
    std::vector<axis*> which;
    for (const auto& arg : cmd.args) {
        auto* a = find_axis(arg.letter);
        if (!a) return error(ms2000::unrecognized_axis);
        which.push_back(a);
    }
    if (which.empty())
        for (auto& a : axes_)
            which.push_back(&a);
    // HOME drives towards the HM position regardless of the soft limits: the default HM lies far
    // beyond travel, so the stage runs until a limit switch stops it, which is how a stage finds its
    // reference (our reading of the HOME and SETHOME pages, doc §3.1). Reaching the switch is HOME's
    // purpose, so no limit error is logged.
    const double switch_mm = config_.limit_switch_mm;
    for (auto* a : which)
        start_move_between(*a, std::clamp(a->params["SETHOME"], -switch_mm, switch_mm), -switch_mm, switch_mm,
                           now, true, 0);
    return ack();
}

std::string ms2000_model::cmd_sethome(const command_line& cmd, sim_time now) {
    std::vector<std::pair<char, std::string>> q;
    for (const auto& arg : cmd.args) {
        auto* a = find_axis(arg.letter);
        if (!a) return error(ms2000::unrecognized_axis);
        switch (arg.kind) {
            case op::query:
                q.emplace_back(a->letter, fixed(a->params["SETHOME"], 3));
                break;
            case op::plus:
                a->params["SETHOME"] = a->motion.position_mm(now);
                break;
            case op::minus:
                a->params["SETHOME"] = 1000;
                break;
            default:
                a->params["SETHOME"] = arg.value;
        }
    }
    return q.empty() ? ack() : axes_a(q);
}

std::string ms2000_model::cmd_rdstat(const command_line& cmd, sim_time now) {
    if (cmd.args.empty()) return error(ms2000::missing_parameters);
    std::string chars;
    for (const auto& arg : cmd.args) {
        const auto* a = find_axis(arg.letter);
        if (!a) return error(ms2000::unrecognized_axis);
        const bool busy_axis = a->motion.busy(now);
        const double pos = a->motion.position_mm(now);
        const bool upper = pos >= upper_stop(*a), lower = pos <= lower_stop(*a);
        switch (arg.kind) {
            case op::query:
                chars.push_back(busy_axis ? 'B' : 'N');
                break;  // "RS X? Y?" -> ":A NB"
            case op::minus:
                chars.push_back(upper ? 'U' : lower ? 'L' : ' ');
                break;
            case op::plus:
                chars.push_back(!busy_axis                       ? ' '
                                : a->motion.velocity_mm_s() != 0 ? 'S'
                                : a->commanded                   ? 'B'
                                                                 : 'M');
                break;
            default: {
                const int byte = status_byte(*a, now);
                if (cmd.args.size() == 1) return values({std::to_string(byte)});
                chars += std::to_string(byte) + " ";
            }
        }
    }
    // "RS X? Y?" -> ":A NB": characters adjacent and no trailing space (TASI reads them one by one,
    // MM-Tiger looks at index 3).
    while (!chars.empty() && chars.back() == ' ' && std::isdigit(static_cast<unsigned char>(chars.front())))
        chars.pop_back();
    return ":A " + chars + "\r\n";
}

double ms2000_model::upper_stop(const axis& a) const {
    return std::min(a.params.at("SETUP"), config_.limit_switch_mm);
}

double ms2000_model::lower_stop(const axis& a) const {
    return std::max(a.params.at("SETLOW"), -config_.limit_switch_mm);
}

int ms2000_model::status_byte(const axis& a, sim_time now) const {
    // bit0 commanded move, bit1 enabled, bit2 motor active, bit3 joystick enabled, bit4 ramping,
    // bit5 ramping up, bit6 upper limit, bit7 lower limit (doc §2.4).
    const double pos = a.motion.position_mm(now);
    int byte = 0b1010;
    if (a.commanded && a.motion.busy(now)) byte |= 1;
    if (a.motion.moving(now)) byte |= 4;
    if (a.motion.ramping(now)) byte |= 16;
    if (pos >= upper_stop(a)) byte |= 64;
    if (pos <= lower_stop(a)) byte |= 128;
    return byte;
}

std::string ms2000_model::cmd_rdsbyte(const command_line& cmd, sim_time now) {
    // "RB X Y": a colon, then each axis's status byte as one raw byte, not ASCII (doc §2.4; the exact
    // framing is unconfirmed there).
    if (cmd.args.empty()) return error(ms2000::missing_parameters);
    std::string out = ":";
    for (const auto& arg : cmd.args) {
        const auto* a = find_axis(arg.letter);
        if (!a) return error(ms2000::unrecognized_axis);
        out.push_back(static_cast<char>(status_byte(*a, now)));
    }
    return out + "\r\n";
}

std::string ms2000_model::cmd_velocity(const command_line& cmd, sim_time now) {
    // SPIN ("@ X=100 Y=-100 Z"): a motor rate in joystick units, taken here as -128..127 parts of 128
    // of the lead screw's maximum speed (the manual gives no scale); an axis without a value stops.
    // VECTOR ("VE X=2"): mm/s, read back with "VE X?"; 0 stops. Either runs until HALT, another move,
    // or the soft limit ahead, where the firmware logs 34/35 as for a clamped move.
    const bool spin = cmd.verb == "SPIN";
    for (const auto& arg : cmd.args)
        if (!find_axis(arg.letter)) return error(ms2000::unrecognized_axis);
    std::vector<std::pair<char, std::string>> q;
    const double max = screw_.max_speed_mm_s;
    for (const auto& arg : cmd.args) {
        auto& a = *find_axis(arg.letter);
        if (arg.kind == op::query) {
            q.emplace_back(a.letter, trimmed(a.params["VECTOR"], 6));
            continue;
        }
        double velocity = 0;
        if (arg.kind == op::set)
            velocity =
                spin ? std::clamp(arg.value, -128.0, 127.0) / 128.0 * max : std::clamp(arg.value, -max, max);
        if (!spin) a.params["VECTOR"] = velocity;
        start_velocity(a, velocity, now);
    }
    return q.empty() ? ack() : axes_a(q);
}

void ms2000_model::start_velocity(axis& a, double velocity_mm_s, sim_time now) {
    a.limit_error_ahead = 0;
    if (velocity_mm_s == 0) {
        if (a.motion.velocity_mm_s() != 0) a.motion.stop(now);
        return;
    }
    const bool up = velocity_mm_s > 0;
    const double here = a.motion.position_mm(now);
    const double limit = up ? upper_stop(a) : lower_stop(a);
    a.commanded = true;
    if (up ? here >= limit : here <= limit) {  // already there: nothing moves
        a.motion.stop(now);
        log_error(up ? 34 : 35);
        return;
    }
    a.motion = axis_motion::at_velocity(here, velocity_mm_s, limit, now);
    a.limit_error_ahead = up ? 34 : 35;
}

std::string ms2000_model::cmd_joystick(const command_line& cmd) {
    // "J X+" / "J X-" enable or disable the inputs (always answered :A); "J X=n" maps an input to the
    // axis; "J X?" reads the mapping.
    std::vector<std::pair<char, std::string>> q;
    for (const auto& arg : cmd.args) {
        auto* a = find_axis(arg.letter);
        if (!a) return error(ms2000::unrecognized_axis);
        if (arg.kind == op::query) {
            q.emplace_back(a->letter, fixed(a->params["JOYSTICK"], 0));
        } else if (arg.kind == op::set) {
            if (arg.value < 0 || arg.value > 99) return error(ms2000::parameter_out_of_range);
            a->params["JOYSTICK"] = std::round(arg.value);
        }
    }
    return q.empty() ? ack() : axes_a(q);
}

std::string ms2000_model::cmd_axis_param(const command_line& cmd, sim_time now) {
    const param_row& row = *find_param(cmd.verb);
    if (cmd.args.empty()) return error(ms2000::missing_parameters);
    for (const auto& arg : cmd.args)
        if (!find_axis(arg.letter)) return error(ms2000::unrecognized_axis);
    std::vector<std::pair<char, std::string>> q;
    for (const auto& arg : cmd.args) {
        auto& a = *find_axis(arg.letter);
        double& value = a.params[std::string(row.verb)];
        if (arg.kind == op::set || arg.kind == op::bare) {
            double v = arg.value;
            if (row.verb == "SPEED") {
                v = std::clamp(v, screw_.max_speed_mm_s / 1e4, screw_.max_speed_mm_s);
            } else if (row.verb == "CNTS" || row.verb == "Z2B") {
                continue;  // read-only
            } else if (v < row.min || v > row.max || (row.verb == "UM" && v == 0) ||
                       (row.verb == "SETUP" && v <= a.params["SETLOW"]) ||
                       (row.verb == "SETLOW" && v >= a.params["SETUP"])) {
                return error(ms2000::parameter_out_of_range);
            }
            if (row.verb == "UM") {
                // Changing the unit multiplier does not move the stage; only its display changes.
            }
            value = v;
        }
        if (arg.kind == op::query || arg.also_query)
            q.emplace_back(a.letter,
                           row.fixed_decimals ? fixed(value, row.decimals) : trimmed(value, row.decimals));
    }
    (void)now;
    if (q.empty()) return ack();
    return row.reply == shape::a ? axes_a(q) : axes_colon(q);
}

// ---------------------------------------------------------------------------------------------
// Identity, diagnostics, settings

std::string ms2000_model::cmd_build(const command_line& cmd) {
    if (cmd.args.empty()) return config_.build_name + "\r\n";
    const auto& arg = cmd.args.front();
    if (arg.letter == 'X') return ms2000::format_build_x(build_) + "\r\n";
    if (arg.letter == 'Y') {
        if (arg.kind == op::query) return values({build_user_string_});
        if (arg.kind == op::minus)
            build_user_string_.clear();
        else if (arg.kind == op::set && build_user_string_.size() < 20 && arg.value >= 32 && arg.value < 127)
            build_user_string_.push_back(static_cast<char>(arg.value));
        else if (arg.kind == op::set)
            return error(ms2000::parameter_out_of_range);
        return ack();
    }
    if (arg.letter == 'Z') {
        switch (arg.kind) {
            case op::query:
                return values({std::to_string(build_counter_)});
            case op::plus:
                build_counter_ = (build_counter_ + 1) % 65536;
                break;
            case op::minus:
                build_counter_ = (build_counter_ + 65535) % 65536;
                break;
            default:
                if (arg.value < 0 || arg.value > 65535) return error(ms2000::parameter_out_of_range);
                build_counter_ = static_cast<long>(arg.value);
        }
        return ack();
    }
    return error(ms2000::unrecognized_axis);
}

std::string ms2000_model::cmd_info(const command_line& cmd, sim_time now) {
    const char letter = cmd.args.empty() ? 'X' : cmd.args.front().letter;
    const auto* a = find_axis(letter);
    if (!a) return {};  // PYM: no reply before its timeout means "axis absent"
    const auto p = [&](const char* key) { return a->params.at(key); };
    const std::string ax(1, letter);
    // Two 33-character columns per line (PYM/TASI split at 33); "Name: value [CMD] unit".
    const std::vector<std::pair<std::string, std::string>> items = {
        {"Axis Name    : " + ax, "Input Device : " + input_device_name(p("JOYSTICK")) + " [J]"},
        {"Max Lim      : " + fixed(p("SETUP"), 3) + " [SU]mm",
         "Min Lim      : " + fixed(p("SETLOW"), 3) + " [SL]mm"},
        {"Ramp Time    : " + fixed(p("ACCEL"), 0) + " [AC]ms",
         "Ramp Length  : " + std::to_string(static_cast<long>(p("ACCEL") * p("SPEED") * p("CNTS") / 2000)) +
             " enc"},
        {"Run Speed    : " + fixed(p("SPEED"), 5) + " [S]mm/s",
         "vmax_enc     : " + std::to_string(static_cast<long>(screw_.max_speed_mm_s * p("CNTS"))) + " enc"},
        {"dv_enc       : 4", "Servo Lp Time: 1 ms"},
        {"Backlash     : " + fixed(p("BACKLASH"), 5) + " [B]mm",
         "Overshoot    : " + fixed(p("OVERSHOOT"), 5) + " [O]mm"},
        {"Kp           : " + fixed(p("KP"), 0) + " [KP]", "Ki           : " + fixed(p("KI"), 0) + " [KI]"},
        {"Kv           : " + fixed(p("KV"), 0) + " [KV]", "Kd           : " + fixed(p("KD"), 0) + " [KD]"},
        {"Axis Enable  : 1 [MC]", "Motor Enable : " + fixed(p("MOTCTRL"), 0)},
        {"CMD_stat     : NO_MOVE", "Move_stat    : " + std::string(a->motion.busy(now) ? "MOVING" : "IDLE")},
        {"Current pos  : " + fixed(a->motion.position_mm(now), 5) + " mm",
         "Target pos   : " + fixed(a->motion.target_mm(), 5) + " mm"},
        {"Enc Cnts/mm  : " + fixed(p("CNTS"), 2) + " [C]", "Unit Mult    : " + fixed(p("UM"), 4) + " [UM]"},
        {"Finish Error : " + fixed(p("PCROS"), 6) + " [PC]mm",
         "Drift Error  : " + fixed(p("ERROR"), 6) + " [E]mm"},
        {"Wait Cycles  : " + fixed(p("WAIT"), 0) + " [WT]",
         "Home Pos     : " + fixed(p("SETHOME"), 3) + " [HM]mm"},
        {"Lead Screw   : " + std::string(1, screw_.id) + " " + fixed(screw_.pitch_mm, 2) + "mm",
         "Max Speed    : " + fixed(screw_.max_speed_mm_s, 2) + " mm/s"},
        {"AutoAlign    : " + fixed(p("AALIGN"), 0) + " [AA]",
         "Joystick Spd : " + fixed(p("JSSPD"), 0) + " [JS]%"},
        {"Encoder Res  : " + fixed(screw_.encoder_nm, 1) + " nm",
         "Axis Index   : " + fixed(p("Z2B"), 0) + " [Z2B]"},
        {"Lim Status   : " + std::string(a->motion.position_mm(now) >= upper_stop(*a)   ? "U"
                                         : a->motion.position_mm(now) <= lower_stop(*a) ? "L"
                                                                                        : "-"),
         "Sys Ver      : " + config_.version},
        {"TTL IN0 mode : " + std::to_string(ttl_.in0_mode) + " [TTL]",
         "TTL OUT0 mode: " + std::to_string(ttl_.out0_mode) + " [TTL]"},
        {"Build        : " + config_.build_name,
         "Error Count  : " + std::to_string(errors_.size()) + " [DU]"},
    };
    std::string out;
    for (const auto& [left, right] : items) {
        std::string l = left.substr(0, 32);
        l.resize(33, ' ');
        std::string r = right.substr(0, 32);
        r.resize(33, ' ');
        out += l + r + "\r";
    }
    out.back() = '\r';
    return out + "\n";
}

std::string ms2000_model::cmd_dump(const command_line& cmd) {
    const auto* x = cmd.find('X');
    const auto* y = cmd.find('Y');
    // "DU X" clears the error log; "DU X?" (a client reading what INFO's "Error Count [DU]" names) only
    // reads it: a query must not destroy what it asks about.
    if (x && x->kind != op::query) {
        errors_.clear();
        return ack();
    }
    if (y || x) {
        std::vector<std::string> codes;
        for (const int e : errors_)
            codes.push_back(std::to_string(e));
        return values(codes);
    }
    return ack();
}

std::string ms2000_model::cmd_saveset(const command_line& cmd, sim_time now) {
    if (cmd.find('Z')) {
        // ":" when the flash write starts, "A" when it ends (doc §1).
        queue_output(now + ms(static_cast<double>(config_.flash_write_time.count())), "A\r\n");
        return ":";
    }
    return ack();
}

std::string ms2000_model::cmd_rtime(const command_line& cmd, sim_time now) {
    std::vector<std::pair<char, std::string>> q;
    for (const auto& arg : cmd.args) {
        double* field = arg.letter == 'X'   ? &rt_report_ms_
                        : arg.letter == 'Z' ? &rt_dwell_ms_
                        : arg.letter == 'F' ? &rt_f_
                                            : nullptr;
        if (arg.letter == 'M') {  // "RT M+" starts serial position reports, "RT M-" stops them
            if (arg.kind == op::plus) {
                reporting_ = true;
                report_start_ = now;
                next_position_report_ = now;
            } else if (arg.kind == op::minus) {
                reporting_ = false;
                next_position_report_.reset();
            }
            continue;
        }
        if (!field) return error(ms2000::unrecognized_axis);
        if (arg.kind == op::query)
            q.emplace_back(arg.letter, trimmed(*field, 3));
        else if (arg.kind == op::set || arg.kind == op::bare) {
            if (arg.value < 0) return error(ms2000::parameter_out_of_range);
            *field = arg.value;
        }
    }
    return q.empty() ? ack() : axes_a(q);
}

std::string ms2000_model::cmd_ttl(const command_line& cmd) {
    if (cmd.args.empty()) return values({ttl_.out0_mode == 1 ? "1" : "0"});
    std::vector<std::pair<char, std::string>> q;
    for (const auto& arg : cmd.args) {
        int* field = nullptr;
        switch (arg.letter) {
            case 'X':
                field = &ttl_.in0_mode;
                break;
            case 'Y':
                field = &ttl_.out0_mode;
                break;
            case 'Z':
                field = &ttl_.aux_state;
                break;
            case 'F':
                field = &ttl_.polarity;
                break;
            case 'R':
                field = &ttl_.aux_mask;
                break;
            case 'T':
                field = &ttl_.aux_mode;
                break;
            default:
                return error(ms2000::unrecognized_axis);
        }
        if (arg.kind == op::query) {
            q.emplace_back(arg.letter, std::to_string(*field));
        } else if (arg.kind == op::set || arg.kind == op::bare) {
            if (arg.value < -1 || arg.value > 255) return error(ms2000::parameter_out_of_range);
            *field = static_cast<int>(arg.value);
        }
    }
    return q.empty() ? ack() : axes_a(q);
}

// ---------------------------------------------------------------------------------------------
// Time

std::optional<sim_time> ms2000_model::next_internal_event() const {
    std::optional<sim_time> best;
    const auto consider = [&best](std::optional<sim_time> t) {
        if (t && (!best || *t < *best)) best = t;
    };
    const auto done = motion_done_at();
    if (array_.state == 'M' || array_.state == 'S') consider(done);
    consider(array_.next_step);
    if (ring_.waiting_arrival) consider(done);
    consider(ring_.next_step);
    if (scan_.running) consider(done);
    consider(crisp_lock_at_);
    consider(autofocus_done_at_);
    consider(next_position_report_);
    return best;
}

std::optional<sim_time> ms2000_model::next_event() const {
    auto best = next_internal_event();
    if (!pending_.empty() && (!best || pending_.front().at < *best)) best = pending_.front().at;
    return best;
}

void ms2000_model::advance(sim_time now) {
    // SPIN/VECTOR motions that reached their soft limit by now.
    for (auto& a : axes_) {
        if (a.limit_error_ahead != 0 && a.motion.velocity_mm_s() != 0 && !a.motion.moving(now)) {
            log_error(a.limit_error_ahead);
            a.limit_error_ahead = 0;
        }
    }
    // Module events in time order, so that chained moves start at exact simulated times.
    for (int guard = 0; guard < 1000000; ++guard) {
        const auto t = next_internal_event();
        if (!t || *t > now) break;
        const auto at = *t;
        if (crisp_lock_at_ && *crisp_lock_at_ <= at) crisp_settle_lock(at);
        if (autofocus_done_at_ && *autofocus_done_at_ <= at) autofocus_done_at_.reset();
        const auto done = motion_done_at();
        if ((array_.state == 'M' || array_.state == 'S') && done <= at) {
            array_.state = 'A';
            if (array_.self_scan) {
                array_.state = 'D';
                array_.next_step = at + ms(rt_dwell_ms_);
            }
        }
        if (array_.next_step && *array_.next_step <= at) {
            array_.next_step.reset();
            array_.state = 'N';
            array_next(at);
        }
        if (ring_.waiting_arrival && done <= at) {
            ring_.waiting_arrival = false;
            if (ring_.autoplay) ring_.next_step = at + ms(rt_dwell_ms_);
        }
        if (ring_.next_step && *ring_.next_step <= at) {
            ring_.next_step.reset();
            ring_next(at);
        }
        if (scan_.running && done <= at) scan_step(at);
        if (next_position_report_ && *next_position_report_ <= at) {
            queue_output(at, position_report_line(at));
            next_position_report_ = at + ms(std::max(rt_report_ms_, 1.0));
        }
    }
}

void ms2000_model::queue_output(sim_time at, std::string bytes) {
    const auto it = std::upper_bound(pending_.begin(), pending_.end(), at,
                                     [](sim_time t, const timed_output& o) { return t < o.at; });
    pending_.insert(it, timed_output{at, std::move(bytes)});
}

std::string ms2000_model::position_report_line(sim_time at) const {
    // "T:   400    0.0    0.1": time in ms since the start, then the axes of the RM Y mask.
    const auto elapsed_ms = std::chrono::duration_cast<std::chrono::milliseconds>(at - report_start_).count();
    auto pad = [](std::string text, std::size_t width) {
        if (text.size() < width) text.insert(0, width - text.size(), ' ');
        return text;
    };
    std::string line = "T:" + pad(std::to_string(elapsed_ms), 6);
    for (std::size_t i = 0; i < axes_.size(); ++i)
        if (ring_.axis_byte & (1 << i)) line += " " + pad(fixed(position_units(axes_[i].letter, at), 1), 6);
    return line + "\r\n";
}

std::string ms2000_model::cmd_zstack(const command_line& cmd, sim_time now) {
    // "ZS M?": 0 while no stack runs, else 1 (slices counting up) or 2 (a triangle stack on its way back).
    const auto stack_direction = [&] { return !zstack_.active ? 0 : zstack_.direction > 0 ? 1 : 2; };
    // Settings apply as they are read: one refused keeps those before it.
    const letter_parameter letters[] = {
        {'X', [&] { return trimmed(zstack_.dz_units, 4); }, assigns(zstack_.dz_units)},
        {'Y', [&] { return std::to_string(zstack_.slices); },
         [&](double v) {
             if (v < 1 || v > 32767) return ms2000::parameter_out_of_range;
             zstack_.slices = static_cast<int>(v);
             return 0;
         }},
        {'Z', [&] { return std::to_string(zstack_.mode); },
         [&](double v) {
             if (v != 0 && v != 1) return ms2000::parameter_out_of_range;
             zstack_.mode = static_cast<int>(v);
             return 0;
         }},
        {'F', nullptr, ignores},  // stack timeout: accepted
        {'T', [&] { return std::to_string(zstack_.index); }, nullptr},
        {'M', [&] { return std::to_string(stack_direction()); },
         [&](double v) {
             if (v == 0) zstack_.active = false;  // "ZS M=0" aborts
             return 0;
         }},
    };
    (void)now;
    const auto outcome = apply_letter_parameters(cmd, letters);
    if (outcome.error != 0) return error(outcome.error);
    return outcome.answers.empty() ? ack() : axes_a(outcome.answers);
}

void ms2000_model::zstack_pulse(sim_time now) {
    auto* z = find_axis('Z');
    if (!z) return;
    if (!zstack_.active) {  // the first pulse starts the stack where Z is
        zstack_ =
            zstack_state{zstack_.dz_units, zstack_.slices, zstack_.mode, 0, 1, z->motion.target_mm(), true};
        return;
    }
    if (zstack_.index + zstack_.direction >= zstack_.slices || zstack_.index + zstack_.direction < 0) {
        if (zstack_.mode == 0) {
            zstack_.index = 0;  // sawtooth: back to the first slice
        } else {
            zstack_.direction = -zstack_.direction;  // triangle: turn around
            zstack_.index += zstack_.direction;
        }
    } else {
        zstack_.index += zstack_.direction;
    }
    start_move(*z, zstack_.start_mm + zstack_.index * zstack_.dz_units / units_per_mm(*z), now);
}

std::vector<timed_output> ms2000_model::take_output(sim_time now) {
    advance(now);
    std::vector<timed_output> out;
    while (!pending_.empty() && pending_.front().at <= now) {
        out.push_back(std::move(pending_.front()));
        pending_.pop_front();
    }
    return out;
}

std::optional<timed_output> ms2000_model::ttl_pulse(sim_time now) {
    advance(now);
    ++ttl_edges_;
    if (has_module(config_, module::ttl_report)) {
        // TTL_REPORT_INT: every other IN0 function is off; any non-zero TTL X enables the interrupt.
        if (ttl_.in0_mode == 0) return std::nullopt;
        // Seed 003 timing: initial read delay td (3-10 us), ta (11-13 us) per further axis, serial
        // transmit delay ts (110-500 us), then the bytes at the baud rate.
        constexpr double td_us = 5, ta_us = 12, ts_us = 200;
        ms2000::report_frame frame;
        double latch_us = td_us;
        for (const auto& a : axes_) {
            const auto at = now + sim_time{static_cast<long long>(latch_us)};
            const double counts = std::round(a.motion.position_mm(at) * screw_.counts_per_mm);
            frame.axes.push_back(
                {a.letter, static_cast<std::int32_t>(std::clamp(counts, -2147483648.0, 2147483647.0))});
            latch_us += ta_us;
        }
        const auto bytes = ms2000::encode_report(frame, config_.report_format);
        const sim_time start = now + sim_time{static_cast<long long>(latch_us - ta_us + ts_us)};
        if (now < report_busy_until_) {
            log_error(87);  // TTL_REPORT_BUFFER_OVERRUN: the previous frame is still going out
            ++reports_dropped_;
            return std::nullopt;
        }
        const double transmit_us = static_cast<double>(bytes.size()) * 10.0 * 1e6 / config_.baud;
        report_busy_until_ = start + sim_time{static_cast<long long>(std::ceil(transmit_us))};
        ++reports_sent_;
        return timed_output{start, std::string(bytes.begin(), bytes.end())};
    }
    switch (ttl_.in0_mode) {
        case 1:
            if (has_module(config_, module::ring_buffer)) ring_next(now);
            break;
        case 2:
            for (auto& a : axes_)
                if (a.last_relative_mm != 0) start_move(a, a.motion.target_mm() + a.last_relative_mm, now);
            break;
        case 4:
            zstack_pulse(now);
            break;
        case 5:  // TTL-started serial position reports: each edge toggles them
            reporting_ = !reporting_;
            if (reporting_) {
                report_start_ = now;
                next_position_report_ = now;
            } else {
                next_position_report_.reset();
            }
            break;
        case 6:
            if (has_module(config_, module::scan) && !scan_.running) {
                command_line start;
                start.verb = "SCAN";
                cmd_scan(start, now);
            }
            break;
        case 7:
            if (has_module(config_, module::array)) {
                if (array_.state == 'I' || (array_.state == 'C' && !array_.graceful))
                    array_start(now, false, false);
                else if (array_.state != 'C' && array_.state != 'M')
                    array_next(now);
            }
            break;
        default:
            break;
    }
    return std::nullopt;
}

nlohmann::json ms2000_model::state(sim_time now) const {
    nlohmann::json j;
    j["name"] = config_.name;
    j["build"] = config_.build_name;
    j["version"] = config_.version;
    j["time_us"] = now.count();
    j["busy"] = busy(now);
    j["lead_screw"] = std::string(1, screw_.id);
    auto& axes = j["axes"];
    axes = nlohmann::json::object();
    for (const auto& a : axes_) {
        const double um = units_per_mm(a);
        axes[std::string(1, a.letter)] = {{"position", a.motion.position_mm(now) * um},
                                          {"target", a.motion.target_mm() * um},
                                          {"busy", a.motion.busy(now)},
                                          // Simulated times of the last motion (duration checks).
                                          {"motion_start_us", a.motion.start().count()},
                                          {"motion_end_us", a.motion.motion_end().count()},
                                          {"settled_us", a.motion.settled().count()},
                                          {"speed", a.params.at("SPEED")},
                                          {"accel_ms", a.params.at("ACCEL")},
                                          {"upper_limit", a.params.at("SETUP")},
                                          {"lower_limit", a.params.at("SETLOW")},
                                          {"unit_multiplier", um}};
    }
    auto modules = nlohmann::json::array();
    for (const auto m : config_.modules)
        modules.push_back(std::string(ms2000::module_id(m)));
    j["modules"] = modules;
    j["ttl"] = {{"in0_mode", ttl_.in0_mode}, {"out0_mode", ttl_.out0_mode}};
    auto slots = nlohmann::json::array();
    for (const auto& s : ring_.slots)
        slots.push_back(s);
    j["ring_buffer"] = {{"count", ring_.slots.size()},  {"pointer", ring_.pointer},
                        {"axis_byte", ring_.axis_byte}, {"mode", ring_.mode},
                        {"autoplay", ring_.autoplay},   {"slots", slots}};
    j["array"] = {{"state", std::string(1, array_.state)},
                  {"index", array_.index},
                  {"columns", array_.columns},
                  {"rows", array_.rows},
                  {"dx_mm", array_.dx_mm},
                  {"dy_mm", array_.dy_mm},
                  {"self_scan", array_.self_scan}};
    j["scan"] = {{"running", scan_.running},
                 {"line", scan_.line},
                 {"lines", scan_.lines},
                 {"pixels", scan_.pixels},
                 {"pattern", scan_.pattern}};
    j["errors"] = errors_;
    j["reports_sent"] = reports_sent_;
    j["reports_dropped"] = reports_dropped_;  // triggers that met a frame still going out (error 87)
    j["ttl_edges"] = ttl_edges_;              // edges on IN0 so far, whatever they did
    j["planar_correction"] = {{"points", plane_points_.size()}, {"enabled", plane_enabled_}};
    j["crisp_state"] = std::string(1, crisp_state_);
    j["led"] = led_;
    j["dac_volts"] = dac_volts_;
    return j;
}

}  // namespace gw::devices::sim
