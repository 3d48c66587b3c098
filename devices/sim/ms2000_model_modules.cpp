// The firmware modules of the simulated MS-2000: RING BUFFER, ARRAY MODULE, SCAN MODULE, DAC OUT,
// LED DIMMER, PLANAR CORRECTION, CRISP and AUTOFOCUS (seed 000 sections; doc §3.3-3.12).
#include <algorithm>
#include <cmath>
#include <limits>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/error.hpp"
#include "devices/sim/letter_parameters.hpp"
#include "devices/sim/ms2000_model.hpp"

namespace gw::devices::sim {

namespace {

using op = line_argument::op;

std::string num(double value, int decimals = 6) {
    return ms2000::format_number(value, decimals);
}

bool is_set(const line_argument& a) {
    return a.kind == op::set || a.kind == op::bare;
}

constexpr double not_loaded = std::numeric_limits<double>::quiet_NaN();

}  // namespace

// ---------------------------------------------------------------------------------------------
// RING BUFFER: "LD X=### Y=###", "RM [X=control] [Y=axis_byte] [Z=pointer] [F=mode]"

std::string ms2000_model::cmd_load(const command_line& cmd, sim_time now) {
    if (cmd.args.empty()) return error(ms2000::missing_parameters);
    std::vector<std::pair<char, std::string>> q;
    std::array<double, 4> slot{not_loaded, not_loaded, not_loaded, not_loaded};
    bool store = false;
    for (const auto& arg : cmd.args) {
        const auto it =
            std::find_if(axes_.begin(), axes_.end(), [&](const axis& a) { return a.letter == arg.letter; });
        if (it == axes_.end()) return error(ms2000::unrecognized_axis);
        const auto index = static_cast<std::size_t>(it - axes_.begin());
        if (index >= slot.size()) return error(ms2000::unrecognized_axis);
        if (arg.kind == op::query) {
            // "LD X?" -> the coordinates of the next move.
            double value = 0;
            if (!ring_.slots.empty()) value = ring_.slots[ring_.pointer % ring_.slots.size()][index];
            q.emplace_back(arg.letter, num(std::isnan(value) ? 0 : value, 1));
            continue;
        }
        store = true;
        slot[index] = arg.kind == op::plus ? it->motion.position_mm(now) * units_per_mm(*it) : arg.value;
    }
    if (store) {
        if (ring_.slots.size() >= ring_buffer_slots) return error(ms2000::operation_failed);  // full
        ring_.slots.push_back(slot);
    }
    return q.empty() ? ack() : axes_a(q);
}

void ms2000_model::ring_next(sim_time now) {
    if (ring_.slots.empty()) return;
    if (ring_.pointer >= ring_.slots.size()) ring_.pointer = 0;
    const auto& slot = ring_.slots[ring_.pointer];
    for (std::size_t i = 0; i < axes_.size() && i < slot.size(); ++i) {
        if (!(ring_.axis_byte & (1 << i)) || std::isnan(slot[i])) continue;
        start_move(axes_[i], slot[i] / units_per_mm(axes_[i]), now);
    }
    ring_.pointer = (ring_.pointer + 1) % ring_.slots.size();
    ring_.waiting_arrival = true;
    if (ring_.autoplay && ring_.mode == 2 && ring_.pointer == 0) ring_.autoplay = false;  // one-shot
}

std::string ms2000_model::cmd_rbmode(const command_line& cmd, sim_time now) {
    if (cmd.args.empty()) {
        // Acts like a TTL IN0 pulse under the current IN0 mode (doc §3.3, seed ARRAY "RM").
        if (ttl_.in0_mode == 7 && has_module(config_, ms2000::module::array)) {
            if (array_.state == 'C' && array_.graceful) return ack();  // ignored after the last well
            if (array_.state == 'I' || array_.state == 'C')
                array_start(now, false, false);
            else if (array_.state != 'M')
                array_next(now);
            return ack();
        }
        if (!has_module(config_, ms2000::module::ring_buffer)) return ack();
        if (ring_.mode == 2 || ring_.mode == 3) {
            ring_.autoplay = true;
            ring_.pointer = ring_.pointer % std::max<std::size_t>(ring_.slots.size(), 1);
        }
        ring_next(now);
        return ack();
    }
    std::vector<std::pair<char, std::string>> q;
    for (const auto& arg : cmd.args) {
        switch (arg.letter) {
            case 'X':
                if (arg.kind == op::query) {
                    q.emplace_back('X', std::to_string(ring_.slots.size()));
                } else if (is_set(arg)) {
                    if (arg.value == 0) {
                        ring_.slots.clear();
                        ring_.pointer = 0;
                        ring_.autoplay = false;
                        // With TTL X=7, "RM X=0" moves to well (1,1) and starts stepping gracefully.
                        if (ttl_.in0_mode == 7 && has_module(config_, ms2000::module::array))
                            array_start(now, false, true);
                    } else if (arg.value == 1) {
                        if (!has_module(config_, ms2000::module::array))
                            return error(ms2000::parameter_out_of_range);
                        array_start(now, true, false);
                    } else {
                        return error(ms2000::parameter_out_of_range);
                    }
                }
                break;
            case 'Y':
                if (arg.kind == op::query)
                    q.emplace_back('Y', std::to_string(ring_.axis_byte));
                else if (is_set(arg)) {
                    if (arg.value < 0 || arg.value > 255) return error(ms2000::parameter_out_of_range);
                    ring_.axis_byte = static_cast<int>(arg.value);
                }
                break;
            case 'Z':
                if (arg.kind == op::query)
                    q.emplace_back('Z', std::to_string(ring_.pointer));
                else if (is_set(arg)) {
                    if (arg.value < 0 || arg.value >= static_cast<double>(ring_buffer_slots))
                        return error(ms2000::parameter_out_of_range);
                    ring_.pointer = static_cast<std::size_t>(arg.value);
                }
                break;
            case 'F':
                if (arg.kind == op::query)
                    q.emplace_back('F', std::to_string(ring_.mode | (ring_.autoplay ? 128 : 0)));
                else if (is_set(arg)) {
                    const int mode = static_cast<int>(arg.value) & 0x7F;
                    if (mode < 1 || mode > 3) return error(ms2000::parameter_out_of_range);
                    ring_.mode = mode;
                }
                break;
            default:
                return error(ms2000::unrecognized_axis);
        }
    }
    return q.empty() ? ack() : axes_a(q);
}

// ---------------------------------------------------------------------------------------------
// ARRAY MODULE: "ARRAY X=cols Y=rows Z=dx F=dy", "AHOME", "AIJ X=i Y=j"

std::pair<int, int> ms2000_model::array_cell(int index) const {
    const int row = index / array_.columns;
    int column = index % array_.columns;
    if (row % 2 == 1) column = array_.columns - 1 - column;  // serpentine
    return {column + 1, row + 1};
}

void ms2000_model::array_move_to(int index, sim_time now) {
    auto* x = find_axis('X');
    auto* y = find_axis('Y');
    const auto [i, j] = array_cell(index);
    array_.index = index;
    array_.state = 'M';
    if (x) start_move(*x, array_.home_x_mm + (i - 1) * array_.dx_mm, now);
    if (y) start_move(*y, array_.home_y_mm + (j - 1) * array_.dy_mm, now);
}

void ms2000_model::array_start(sim_time now, bool self_scan, bool graceful) {
    array_.self_scan = self_scan;
    array_.graceful = graceful;
    array_.next_step.reset();
    array_move_to(0, now);
}

void ms2000_model::array_next(sim_time now) {
    const int total = array_.columns * array_.rows;
    if (array_.index + 1 < total) {
        array_move_to(array_.index + 1, now);
        return;
    }
    if (array_.self_scan && ring_.mode == 3) {  // RM F=3 also repeats ARRAY scans
        array_move_to(0, now);
        return;
    }
    array_.state = 'C';
    array_.self_scan = false;
}

std::string ms2000_model::cmd_array(const command_line& cmd, sim_time now) {
    if (!find_axis('X') || !find_axis('Y')) return error(ms2000::operation_failed);
    if (cmd.args.empty()) {
        array_start(now, true, false);  // self-scan
        return ack();
    }
    auto next = array_;
    std::vector<std::pair<char, std::string>> q;
    for (const auto& arg : cmd.args) {
        switch (arg.letter) {
            case 'X':
                if (arg.kind == op::query)
                    q.emplace_back('X', std::to_string(array_.columns));
                else if (is_set(arg))
                    next.columns = static_cast<int>(arg.value);
                break;
            case 'Y':
                if (arg.kind == op::query)
                    q.emplace_back('Y', std::to_string(array_.rows));
                else if (is_set(arg))
                    next.rows = static_cast<int>(arg.value);
                break;
            case 'Z':
                if (arg.kind == op::query)
                    q.emplace_back('Z', num(array_.dx_mm));
                else if (is_set(arg))
                    next.dx_mm = arg.value;
                break;
            case 'F':
                if (arg.kind == op::query)
                    q.emplace_back('F', num(array_.dy_mm));
                else if (is_set(arg))
                    next.dy_mm = arg.value;
                break;
            default:
                return error(ms2000::unrecognized_axis);
        }
    }
    if (next.columns < 1 || next.rows < 1 || next.columns > 1000 || next.rows > 1000)
        return error(ms2000::parameter_out_of_range);
    array_ = next;
    return q.empty() ? ack() : axes_a(q);
}

std::string ms2000_model::cmd_ahome(const command_line& cmd, sim_time now) {
    if (cmd.args.empty()) {
        // "AH" alone: the current position becomes well (1,1).
        array_.home_x_mm = position_mm('X', now);
        array_.home_y_mm = position_mm('Y', now);
        return ack();
    }
    std::vector<std::pair<char, std::string>> q;
    for (const auto& arg : cmd.args) {
        double* field = arg.letter == 'X'   ? &array_.home_x_mm
                        : arg.letter == 'Y' ? &array_.home_y_mm
                                            : nullptr;
        if (!field) return error(ms2000::unrecognized_axis);
        if (arg.kind == op::query)
            q.emplace_back(arg.letter, num(*field));
        else if (arg.kind == op::plus)
            *field = position_mm(arg.letter, now);
        else if (is_set(arg))
            *field = arg.value;
    }
    return q.empty() ? ack() : axes_a(q);
}

std::string ms2000_model::cmd_aij(const command_line& cmd, sim_time now) {
    const auto* i = cmd.find('X');
    const auto* j = cmd.find('Y');
    if (!i || !j) return error(ms2000::missing_parameters);
    const int col = static_cast<int>(i->value), row = static_cast<int>(j->value);
    if (col < 1 || col > array_.columns || row < 1 || row > array_.rows)
        return error(ms2000::parameter_out_of_range);
    // Index of (col,row) in the serpentine order, so that a following "next" continues from it.
    const int r = row - 1;
    const int c = r % 2 == 1 ? array_.columns - col : col - 1;
    array_move_to(r * array_.columns + c, now);
    array_.self_scan = false;
    return ack();
}

// ---------------------------------------------------------------------------------------------
// SCAN MODULE: "SCANR X=start Y=stop Z=divide [F=pixels] [R=retrace%]",
// "SCANV X=start Y=stop Z=lines", "SCAN [S|P] [Y=fast] [Z=slow] [F=pattern]"

std::string ms2000_model::cmd_scanr(const command_line& cmd) {
    if (cmd.args.empty()) return error(ms2000::missing_parameters);
    auto next = scan_;  // settings apply only when every argument is taken and nothing is queried
    const double counts = screw_.counts_per_mm;
    bool pixels_given = false;
    const letter_parameter letters[] = {
        {'X', [&] { return num(scan_.r_start); }, assigns(next.r_start)},
        {'Y', [&] { return num(scan_.r_stop); }, assigns(next.r_stop)},
        {'Z', [&] { return std::to_string(scan_.divide); },
         [&](double v) {
             if (v < 1 || v >= 32768) return ms2000::parameter_out_of_range;
             next.divide = static_cast<int>(v);
             return 0;
         }},
        {'F', [&] { return std::to_string(scan_.pixels); },
         [&](double v) {
             pixels_given = true;
             next.pixels = static_cast<int>(v);
             return 0;
         }},
        {'R', [&] { return num(scan_.retrace_pct); }, assigns(next.retrace_pct)},
    };
    const auto outcome = apply_letter_parameters(cmd, letters);
    if (outcome.error != 0) return error(outcome.error);
    if (!outcome.answers.empty()) return axes_a(outcome.answers);
    // Pixels per line = counts/mm x length / divide; both it and divide must stay below 32768.
    if (pixels_given) {
        if (next.pixels < 1 || next.pixels >= 32768) return error(ms2000::parameter_out_of_range);
        next.r_stop = next.r_start + next.pixels * static_cast<double>(next.divide) / counts;
    } else {
        const double pixels = std::floor(counts * std::abs(next.r_stop - next.r_start) / next.divide);
        if (pixels >= 32768) return error(ms2000::parameter_out_of_range);
        next.pixels = static_cast<int>(pixels);
    }
    scan_ = next;
    return ack();
}

std::string ms2000_model::cmd_scanv(const command_line& cmd) {
    if (cmd.args.empty()) return error(ms2000::missing_parameters);
    auto next = scan_;  // settings apply only when every argument is taken and nothing is queried
    const letter_parameter letters[] = {
        {'X', [&] { return num(scan_.v_start); }, assigns(next.v_start)},
        {'Y', [&] { return num(scan_.v_stop); }, assigns(next.v_stop)},
        {'Z', [&] { return std::to_string(scan_.lines); },
         [&](double v) {
             if (v < 1 || v >= 32768) return ms2000::parameter_out_of_range;
             next.lines = static_cast<int>(v);
             return 0;
         }},
        {'F', nullptr, ignores},  // overshoot time and factor: accepted, not simulated
        {'T', nullptr, ignores},
    };
    const auto outcome = apply_letter_parameters(cmd, letters);
    if (outcome.error != 0) return error(outcome.error);
    if (!outcome.answers.empty()) return axes_a(outcome.answers);
    scan_ = next;
    return ack();
}

std::string ms2000_model::cmd_scan(const command_line& cmd, sim_time now) {
    bool start = cmd.args.empty();
    bool stop = false;
    const auto axes_count = static_cast<double>(axes_.size());
    const auto sets_axis = [&](int& field) {
        return [&field, axes_count](double v) {
            if (v < 0 || v >= axes_count) return ms2000::parameter_out_of_range;
            field = static_cast<int>(v);
            return 0;
        };
    };
    const auto raises = [](bool& flag) {
        return [&flag](double) {
            flag = true;
            return 0;
        };
    };
    const letter_parameter letters[] = {
        {'S', nullptr, raises(start)},
        {'P', nullptr, raises(stop)},
        // Older syntax "SCAN X=1": start; "SCAN X=0": stop.
        {'X', [&] { return std::string(scan_.running ? "S" : "P"); },
         [&](double v) {
             (v != 0 ? start : stop) = true;
             return 0;
         }},
        {'Y', [&] { return std::to_string(scan_.fast_axis); }, sets_axis(scan_.fast_axis)},
        {'Z', [&] { return std::to_string(scan_.slow_axis); }, sets_axis(scan_.slow_axis)},
        {'F', [&] { return std::to_string(scan_.pattern); },
         [&](double v) {
             if (v != 0 && v != 1) return ms2000::parameter_out_of_range;
             scan_.pattern = static_cast<int>(v);
             return 0;
         }},
    };
    const auto outcome = apply_letter_parameters(cmd, letters);
    if (outcome.error != 0) return error(outcome.error);
    if (!outcome.answers.empty()) return axes_a(outcome.answers);
    if (stop) {
        if (scan_.running) {
            scan_.running = false;
            for (auto& a : axes_)
                a.motion.stop(now);
        }
        return ack();
    }
    if (start && !scan_.running) {
        if (static_cast<std::size_t>(std::max(scan_.fast_axis, scan_.slow_axis)) >= axes_.size())
            return error(ms2000::operation_failed);
        scan_.running = true;
        scan_.line = 0;
        scan_.phase = 0;
        // Go to the start of the first line.
        auto& fast = axes_[static_cast<std::size_t>(scan_.fast_axis)];
        auto& slow = axes_[static_cast<std::size_t>(scan_.slow_axis)];
        start_move(fast, scan_.r_start, now, true, screw_.max_speed_mm_s);
        if (scan_.slow_axis != scan_.fast_axis)
            start_move(slow, scan_.v_start, now, true, screw_.max_speed_mm_s);
    }
    return ack();
}

void ms2000_model::scan_step(sim_time now) {
    auto& fast = axes_[static_cast<std::size_t>(scan_.fast_axis)];
    auto& slow = axes_[static_cast<std::size_t>(scan_.slow_axis)];
    const bool reverse = scan_.pattern == 1 && scan_.line % 2 == 1;
    if (scan_.phase == 0) {
        // Scan the line at SPEED.
        start_move(fast, reverse ? scan_.r_start : scan_.r_stop, now);
        scan_.phase = 1;
        return;
    }
    ++scan_.line;
    if (scan_.line >= scan_.lines) {
        scan_.running = false;
        return;
    }
    scan_.phase = 0;
    const double step = scan_.lines > 1 ? (scan_.v_stop - scan_.v_start) / (scan_.lines - 1) : 0;
    const double retrace = screw_.max_speed_mm_s * std::clamp(scan_.retrace_pct, 1.0, 100.0) / 100.0;
    if (scan_.slow_axis != scan_.fast_axis)
        start_move(slow, scan_.v_start + scan_.line * step, now, true, retrace);
    const bool next_reverse = scan_.pattern == 1 && scan_.line % 2 == 1;
    start_move(fast, next_reverse ? scan_.r_stop : scan_.r_start, now, true, retrace);  // raster retrace
}

// ---------------------------------------------------------------------------------------------
// DAC OUT: "WRDAC X=volts" (0..10 V, else ":N-4"); LED DIMMER: "LED X=0..99", "LED X?" -> "X=50 :A"

std::string ms2000_model::cmd_wrdac(const command_line& cmd) {
    const auto* x = cmd.find('X');
    if (!x) return cmd.args.empty() ? error(ms2000::missing_parameters) : error(ms2000::unrecognized_axis);
    if (x->kind == op::query) return axes_a({{'X', num(dac_volts_, 3)}});
    if (x->value < 0 || x->value > 10) return error(ms2000::parameter_out_of_range);
    dac_volts_ = x->value;
    return ack();
}

std::string ms2000_model::cmd_led(const command_line& cmd) {
    if (cmd.args.empty()) return error(ms2000::missing_parameters);
    std::vector<std::pair<char, std::string>> q;
    for (const auto& arg : cmd.args) {
        const auto it = led_.find(arg.letter);
        if (it == led_.end()) return error(ms2000::unrecognized_axis);
        if (is_set(arg)) {
            if (arg.value < 0 || arg.value > 99) return error(ms2000::parameter_out_of_range);
            it->second = std::round(arg.value);
        }
        if (arg.kind == op::query || arg.also_query) q.emplace_back(arg.letter, num(it->second, 0));
    }
    return q.empty() ? ack() : axes_led(q);
}

// ---------------------------------------------------------------------------------------------
// PLANAR CORRECTION: "CCB Z=1..3" store point, 4 enable, 5 disable, 6 corrected Z, 7 clear,
// 8 state (Z/G), 9 Z limit status (N/U/L). Doc §3.7.

double ms2000_model::planar_offset_units(double x_units, double y_units) const {
    if (!plane_ || !plane_enabled_ || plane_points_.empty()) return 0;
    const auto& p = *plane_;
    const auto& ref = plane_points_.front();
    return p[0] * (x_units - ref[0]) + p[1] * (y_units - ref[1]);
}

std::string ms2000_model::cmd_customb(const command_line& cmd, sim_time now) {
    const auto* z = cmd.find('Z');
    if (!z)
        return cmd.args.empty() ? error(ms2000::missing_parameters) : ack();  // X=/Y=/F=/T=: newer firmware
    const int code = static_cast<int>(z->value);
    const double x = position_units('X', now), y = position_units('Y', now), zz = position_units('Z', now);
    switch (code) {
        case 1:
        case 2:
        case 3: {
            const auto index = static_cast<std::size_t>(code - 1);
            if (plane_points_.size() < index) return error(ms2000::operation_failed);  // points in order
            if (plane_points_.size() == index)
                plane_points_.push_back({x, y, zz});
            else
                plane_points_[index] = {x, y, zz};
            return ack();
        }
        case 4: {
            if (plane_points_.size() < 3) return error(ms2000::operation_failed);
            const auto& p1 = plane_points_[0];
            const auto& p2 = plane_points_[1];
            const auto& p3 = plane_points_[2];
            const double ux = p2[0] - p1[0], uy = p2[1] - p1[1], uz = p2[2] - p1[2];
            const double vx = p3[0] - p1[0], vy = p3[1] - p1[1], vz = p3[2] - p1[2];
            const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
            if (std::abs(nz) < 1e-9) return error(ms2000::operation_failed);  // collinear points
            plane_ = std::array<double, 3>{-nx / nz, -ny / nz, 0};
            plane_enabled_ = true;
            return ack();
        }
        case 5:
            plane_enabled_ = false;
            return ack();
        case 6:
            return axes_a({{'Z', std::to_string(std::llround(zz + planar_offset_units(x, y)))}});
        case 7:
            plane_points_.clear();
            plane_.reset();
            plane_enabled_ = false;
            return ack();
        case 8: {
            std::string state = plane_enabled_              ? "Z"
                                : plane_points_.size() >= 3 ? "G"
                                                            : std::to_string(plane_points_.size() + 1);
            return values({state});
        }
        case 9: {
            const auto* za = find_axis('Z');
            if (!za) return values({"N"});
            const double pos = za->motion.position_mm(now);
            return values({pos >= upper_stop(*za) ? "U" : pos <= lower_stop(*za) ? "L" : "N"});
        }
        default:
            return error(ms2000::parameter_out_of_range);
    }
}

// ---------------------------------------------------------------------------------------------
// CRISP "LK": states I idle (LED off), R ready, K trying to lock, F locked, E could not lock
// (doc §3.12). The sample is in focus at config_.focus_plane_um; the focus error is the distance of Z
// from the lock's set point (focus plane plus offset) in nanometres, our reading of the LCD's unit.
// AUTOFOCUS "AF": a focus scan that ends with Z at the focus plane.

namespace {
constexpr double crisp_capture_um = 50;  // beyond this the reflection is too weak to lock on
constexpr long crisp_full_sum = 2400;    // "LK T?" in focus; our figure
}  // namespace

ms2000_model::crisp_reading ms2000_model::crisp_read(sim_time now) const {
    crisp_reading r;
    const auto* z = find_axis('Z');
    if (crisp_state_ == 'I' || !z) return r;  // LED off: no signal
    const double defocus_um = z->motion.position_mm(now) * 1000 - config_.focus_plane_um;
    const bool captured = std::abs(defocus_um) <= crisp_capture_um;
    r.focus_error = std::lround(std::clamp(defocus_um * 1000 - crisp_offset_, -32767.0, 32767.0));
    r.sum = captured ? crisp_full_sum : crisp_full_sum / 8;
    r.snr = captured ? 20.0 : 2.0;
    return r;
}

// The end of "trying to lock": locked, Z servoed to the set point, when the reflection is strong
// enough; otherwise the error state, as when the sample is too far out of focus.
void ms2000_model::crisp_settle_lock(sim_time now) {
    crisp_lock_at_.reset();
    auto* z = find_axis('Z');
    if (!z || std::abs(z->motion.position_mm(now) * 1000 - config_.focus_plane_um) > crisp_capture_um) {
        crisp_state_ = 'E';
        return;
    }
    crisp_state_ = 'F';
    start_move(*z, (config_.focus_plane_um + crisp_offset_ / 1000) / 1000, now, false);
}

std::string ms2000_model::cmd_lock(const command_line& cmd, sim_time now) {
    constexpr auto lock_time = std::chrono::milliseconds(500);
    if (cmd.args.empty()) {  // like a short press of '@': next state
        switch (crisp_state_) {
            case 'I':
                crisp_state_ = 'R';
                break;
            case 'R':
                crisp_state_ = 'K';
                crisp_lock_at_ = now + lock_time;
                break;
            default:
                crisp_state_ = 'R';
                crisp_lock_at_.reset();
        }
        return ack();
    }
    const auto& arg = cmd.args.front();
    const auto reading = crisp_read(now);
    switch (arg.letter) {
        case 'X':
            // "LK X?" -> ":A R": no trailing space, MM-Stage reads the last character.
            if (arg.kind == op::query) return std::string(":A ") + crisp_state_ + "\r\n";
            return ack();
        case 'F': {
            const int code = static_cast<int>(arg.value);
            if (code < 33 || code > 126) return error(ms2000::parameter_out_of_range);
            crisp_lock_at_.reset();
            if (code == 'S') {
                crisp_state_ = 'K';
                crisp_lock_at_ = now + lock_time;
            } else if (code == 'U') {
                crisp_state_ = 'R';
            } else if (code == 'O') {
                crisp_state_ = 'I';
            } else {
                crisp_state_ = static_cast<char>(code);
            }
            return ack();
        }
        case 'Y':
            if (arg.kind == op::query) return values({std::to_string(reading.focus_error)});
            return ack();
        case 'T':
            if (arg.kind == op::query) return values({std::to_string(reading.sum)});
            return ack();
        case 'Z':
            if (arg.kind == op::query) return axes_a({{'Z', ms2000::format_number(crisp_offset_, 1)}});
            if (arg.kind == op::set) {
                if (std::abs(arg.value) > 32767) return error(ms2000::parameter_out_of_range);
                crisp_offset_ = arg.value;
            }
            return ack();
        case 'M':
            if (arg.kind == op::query) return axes_a({{arg.letter, "0"}});
            return ack();
        default:
            return error(ms2000::unrecognized_axis);
    }
}

// "EXTRA X?" (before 9.2o): state, sum and dither error on one line without ":A"; "EXTRA Y?" ("EX Y?"
// from 9.53): the signal-to-noise ratio.
std::string ms2000_model::cmd_extra(const command_line& cmd, sim_time now) const {
    const auto reading = crisp_read(now);
    if (cmd.has_query() && cmd.args.front().letter == 'Y')
        return values({ms2000::format_number(reading.snr, 1)});
    return std::string(1, crisp_state_) + "    " + std::to_string(reading.sum) + "    0 \r\n";
}

std::string ms2000_model::cmd_afocus(const command_line& cmd, sim_time now) {
    if (cmd.args.empty()) {
        auto* z = find_axis('Z');
        if (!z) return error(ms2000::unrecognized_axis);
        start_move(*z, config_.focus_plane_um / 1000, now, true);
        autofocus_done_at_ = std::max(z->motion.settled(), now + std::chrono::milliseconds(1));
        return ack();
    }
    // "AF X?": 1 while the focus scan runs (our reading; the AF syntax is not published).
    if (cmd.has_query()) return values({autofocus_done_at_ ? "1" : "0"});
    return ack();
}

}  // namespace gw::devices::sim
