#include "gateway/gcode/gcode_planner.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "devices/ms2000/host_step_timing.hpp"
#include "devices/ms2000/motion_profile.hpp"

namespace gw::gcode {

namespace {

double motion_seconds(double length_mm, double speed_mm_s, const gcode_options& o) {
    if (length_mm <= 0) return 0;
    return devices::ms2000::move_time_s(length_mm, speed_mm_s, o.ramp_ms) +
           devices::ms2000::settle_after_move_ms(length_mm, o.settle_ms) / 1000.0;
}

// "TTL Y=1", "WRDAC X=2.500": one command each.
constexpr std::size_t ttl_chars = 7;
constexpr std::size_t wrdac_chars = 13;

class null_sink final : public move_sink {
  public:
    void on_move(const planned_move&) override {}
};

}  // namespace

double straight_segment_seconds(double length_mm, double speed_mm_s, const gcode_options& o,
                                bool with_speed) {
    if (length_mm <= 0) return 0;
    return motion_seconds(length_mm, speed_mm_s, o) +
           devices::ms2000::host_move_overhead_s(o.host, with_speed);
}

double estimate_seconds(const planned_move& m, const gcode_options& o) {
    namespace ms = devices::ms2000;
    switch (m.kind) {
        case move_kind::rapid:
        case move_kind::linear:
            // One SPEED (the direction or the feed changes), then one MOVE.
            return straight_segment_seconds(distance(m.start, m.end), m.feed_mm_s, o, true);
        case move_kind::arc: {
            if (m.segments == 0) return 0;
            const auto n = static_cast<double>(m.segments);
            const plane_point s = to_plane(m.start, m.arc.plane);
            const plane_point e = to_plane(m.end, m.arc.plane);
            const double r = (m.arc.start_radius + m.arc.end_radius) / 2;
            const double chord = 2 * r * std::sin(std::abs(m.arc.sweep) / (2 * n));
            const double rise = std::abs(e.n - s.n) / n;
            const double length = std::hypot(chord, rise);
            if (!(chord > 0)) return 0;
            const double speed = std::min(m.feed_mm_s * length / chord, o.max_feed_mm_s);
            // The direction turns at every chord: a SPEED and a MOVE each.
            return n * straight_segment_seconds(length, speed, o, true);
        }
        case move_kind::dwell:
            return m.dwell_ms / 1000.0;
        case move_kind::ttl:
            return ms::command_round_trip_s(o.host, ttl_chars);
        case move_kind::analog:
            return ms::command_round_trip_s(o.host, wrdac_chars);
    }
    return 0;
}

gcode_planner::gcode_planner(std::istream& in, const gcode_options& options)
    : options_(options), reader_(in, options.max_line_chars), interpreter_(options) {
    if (auto why = validate(options_)) {
        error_ = gcode_error{0, 0, "bad options: " + *why};
        done_ = true;
    }
}

void gcode_planner::include(const vec3& p) {
    totals_.min = {std::min(totals_.min.x, p.x), std::min(totals_.min.y, p.y), std::min(totals_.min.z, p.z)};
    totals_.max = {std::max(totals_.max.x, p.x), std::max(totals_.max.y, p.y), std::max(totals_.max.z, p.z)};
}

void gcode_planner::account(planned_move& m) {
    m.estimated_s = estimate_seconds(m, options_);
    ++totals_.moves;
    totals_.segments +=
        (m.kind == move_kind::rapid || m.kind == move_kind::linear || m.kind == move_kind::arc) ? m.segments
                                                                                                : 0;
    totals_.estimated_s += m.estimated_s;
    include(m.end);
    if (m.kind == move_kind::arc) {
        // The arc's extremes: where it crosses a multiple of 90 degrees in its plane.
        const double step = std::numbers::pi / 2;
        const double a0 = m.arc.start_angle;
        const double a1 = a0 + m.arc.sweep;
        const double lo = std::min(a0, a1);
        const double hi = std::max(a0, a1);
        for (double k = std::ceil(lo / step); k * step <= hi; k += 1) {
            const double fraction = (k * step - a0) / m.arc.sweep;
            include(arc_point(m.arc, fraction));
        }
    }
}

bool gcode_planner::read_block() {
    while (!done_) {
        const auto text = reader_.next();
        if (!text) {
            if (reader_.error()) {
                error_ = reader_.error();
                done_ = true;
                return false;
            }
            if (percent_open_) {
                interpreter_.warnings().add(warning_kind::no_closing_percent, reader_.line(),
                                            "no closing '%': the end of the file ends the program");
            }
            interpreter_.finish(reader_.line(), pending_);
            done_ = true;
            return !pending_.empty();
        }
        if (auto e = lex_line(*text, reader_.line(), block_)) {
            error_ = std::move(e);
            done_ = true;
            return false;
        }
        if (block_.percent) {
            if (!seen_block_ && !percent_open_) {
                percent_open_ = true;  // tape start
                continue;
            }
            percent_open_ = false;  // end of the program: the rest of the file is ignored
            interpreter_.finish(reader_.line(), pending_);
            done_ = true;
            return !pending_.empty();
        }
        if (!block_.words.empty()) seen_block_ = true;
        if (auto e = interpreter_.execute(block_, pending_)) {
            error_ = std::move(e);
            done_ = true;
            return false;
        }
        if (interpreter_.ended()) {
            done_ = true;
            // Look for text after M02/M30 (ignored); only the next non-blank line, to stay cheap.
            while (const auto rest = reader_.next()) {
                if (rest->find_first_not_of(" \t") == std::string_view::npos) continue;
                if (rest->find_first_not_of(" \t%") != std::string_view::npos) {
                    interpreter_.warnings().add(warning_kind::text_after_end, reader_.line(),
                                                "text after M02/M30 ignored");
                }
                break;
            }
        }
        if (!pending_.empty()) return true;
    }
    return false;
}

const planned_move* gcode_planner::next() {
    if (pending_at_ >= pending_.size()) {
        pending_.clear();
        pending_at_ = 0;
        if (error_ || !read_block()) {
            pending_.clear();
            return nullptr;
        }
    }
    current_ = pending_[pending_at_++];
    account(current_);
    return &current_;
}

plan_summary gcode_planner::summary() const {
    plan_summary s = totals_;
    s.lines = reader_.line();
    s.warnings = interpreter_.warnings().texts();
    return s;
}

std::variant<plan_summary, gcode_error> plan_program(std::istream& in, const gcode_options& options,
                                                     move_sink& sink) {
    gcode_planner planner(in, options);
    while (const planned_move* m = planner.next())
        sink.on_move(*m);
    if (planner.error()) return *planner.error();
    return planner.summary();
}

std::variant<plan_summary, gcode_error> check_program(std::istream& in, const gcode_options& options) {
    null_sink sink;
    return plan_program(in, options, sink);
}

}  // namespace gw::gcode
