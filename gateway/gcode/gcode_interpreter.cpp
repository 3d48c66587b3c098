#include "gateway/gcode/gcode_interpreter.hpp"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

namespace gw::gcode {

namespace {

constexpr double mm_per_inch = 25.4;
constexpr double max_dwell_ms = 99'999'999;  // FANUC IS-B P range

// "12.5", "-0.001", "1000": up to 6 decimals, no trailing zeros.
std::string num(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6f", v);
    std::string s(buf);
    if (s.find('.') != std::string::npos) {
        while (s.back() == '0')
            s.pop_back();
        if (s.back() == '.') s.pop_back();
    }
    if (s == "-0") s = "0";
    return s;
}

std::string code_name(char letter, int code) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "%c%02d", letter, code);
    return buf;
}

gcode_error error_at(int line, const gcode_word& w, std::string message) {
    return gcode_error{line, w.column, std::move(message)};
}

bool integral(double v) {
    return std::isfinite(v) && v == std::floor(v) && std::abs(v) < 1e9;
}

enum group : std::uint8_t { g_motion, g_plane, g_distance, g_units, g_polar, g_dwell, group_count };
const char* group_names[group_count] = {"motion (G00-G03)", "plane (G17-G19)", "distance (G90/G91)",
                                        "units (G20/G21)",  "polar (G15/G16)", "dwell"};

}  // namespace

struct gcode_interpreter::block_codes {
    const gcode_word* g_word[group_count] = {};
    int g_code[group_count] = {};
    const gcode_word* m_word = nullptr;
    int m_code = 0;
    const gcode_word* axis[3] = {};    // X, Y, Z
    const gcode_word* offset[3] = {};  // I, J, K
    const gcode_word* r = nullptr;
    const gcode_word* f = nullptr;
    const gcode_word* p = nullptr;
    const gcode_word* o = nullptr;
    int other_words = 0;  // words besides N and O
};

gcode_interpreter::gcode_interpreter(const gcode_options& options)
    : options_(options), analog_(analog_mapping_for(options)) {}

std::optional<gcode_error> gcode_interpreter::read_codes(const gcode_block& block, block_codes& c) {
    const int line = block.line;
    for (const auto& w : block.words) {
        auto once = [&](const gcode_word*& slot) -> std::optional<gcode_error> {
            if (slot != nullptr)
                return error_at(line, w,
                                std::string(1, w.letter) + " given twice in one block (first at column " +
                                    std::to_string(slot->column) + ")");
            slot = &w;
            return std::nullopt;
        };
        std::optional<gcode_error> e;
        if (w.letter != 'N' && w.letter != 'O') ++c.other_words;
        switch (w.letter) {
            case 'N':
                if (!integral(w.value) || w.decimal_point || w.value < 0)
                    return error_at(line, w,
                                    "N (block number) must be a whole number without a decimal point");
                if (w.value == 0) warnings_.add(warning_kind::n_zero, line, "N0 is not a valid block number");
                break;
            case 'O':
                e = once(c.o);
                break;
            case 'G': {
                if (!integral(w.value)) return error_at(line, w, "unsupported code G" + num(w.value));
                const int code = static_cast<int>(w.value);
                group gr = group_count;
                switch (code) {
                    case 0:
                    case 1:
                    case 2:
                    case 3:
                        gr = g_motion;
                        break;
                    case 4:
                        gr = g_dwell;
                        break;
                    case 15:
                    case 16:
                        gr = g_polar;
                        break;
                    case 17:
                    case 18:
                    case 19:
                        gr = g_plane;
                        break;
                    case 20:
                    case 21:
                        gr = g_units;
                        break;
                    case 90:
                    case 91:
                        gr = g_distance;
                        break;
                    default:
                        return error_at(line, w, "unsupported code " + code_name('G', code));
                }
                if (c.g_word[gr] != nullptr) {
                    return error_at(line, w,
                                    code_name('G', code) + " and " + code_name('G', c.g_code[gr]) +
                                        " in one block: both are in the " + group_names[gr] + " group");
                }
                c.g_word[gr] = &w;
                c.g_code[gr] = code;
                break;
            }
            case 'M': {
                if (!integral(w.value)) return error_at(line, w, "unsupported code M" + num(w.value));
                const int code = static_cast<int>(w.value);
                if (code != 2 && code != 3 && code != 5 && code != 30)
                    return error_at(line, w, "unsupported code " + code_name('M', code));
                if (c.m_word != nullptr)
                    return error_at(
                        line, w, code_name('M', code) + " and " + code_name('M', c.m_code) + " in one block");
                c.m_word = &w;
                c.m_code = code;
                break;
            }
            case 'X':
            case 'Y':
            case 'Z':
                e = once(c.axis[w.letter - 'X']);
                break;
            case 'I':
            case 'J':
            case 'K':
                e = once(c.offset[w.letter - 'I']);
                break;
            case 'R':
                e = once(c.r);
                break;
            case 'F':
                e = once(c.f);
                if (!e && w.value < 0) return error_at(line, w, "negative feed F" + num(w.value));
                break;
            case 'P':
                e = once(c.p);
                break;
            default:
                return error_at(line, w,
                                std::string("unsupported word ") + w.letter + num(w.value) +
                                    " (the Tracer subset has G, M, X, Y, Z, I, J, K, R, F, P and N)");
        }
        if (e) return e;
    }
    if (c.o != nullptr && c.other_words > 0)
        return error_at(line, *c.o, "O (program number) must be alone in its block");
    return std::nullopt;
}

double gcode_interpreter::plain_value(const gcode_word& w, double least_increment, const char* unit_name) {
    if (w.decimal_point || w.value == 0) return w.value;
    const bool fanuc = options_.decimal_point == decimal_point_reading::least_increment;
    const double read = fanuc ? w.value * least_increment : w.value;
    const double other = fanuc ? w.value : w.value * least_increment;
    warnings_.add(warning_kind::no_decimal_point, line_,
                  std::string(1, w.letter) + num(w.value) + " has no decimal point: read as " + num(read) +
                      " " + unit_name + " (decimal_point=" + (fanuc ? "least_increment" : "calculator") +
                      "; the other reading gives " + num(other) + " " + unit_name + ")");
    return read;
}

double gcode_interpreter::length(const gcode_word& w) {
    const double v = plain_value(w, inches_ ? 0.0001 : 0.001, inches_ ? "inch" : "mm");
    return v * (inches_ ? mm_per_inch : 1.0) * options_.xyz_scale;
}

double gcode_interpreter::angle(const gcode_word& w) {
    return plain_value(w, 0.001, "degrees");
}

double gcode_interpreter::feed_mm_s(int line) {
    double v = *feed_mm_min_ / 60.0 * options_.speed_scale;
    if (v > options_.max_feed_mm_s) {
        warnings_.add(warning_kind::feed_clamped, line,
                      "feed " + num(v) + " mm/s clamped to max_feed_mm_s " + num(options_.max_feed_mm_s));
        v = options_.max_feed_mm_s;
    }
    return v;
}

std::optional<gcode_error> gcode_interpreter::execute(const gcode_block& block,
                                                      std::vector<planned_move>& out) {
    const int line = block.line;
    line_ = line;
    if (block.percent || ended_) return std::nullopt;
    if (block.block_delete) {
        warnings_.add(warning_kind::block_delete, line,
                      "'/' (block delete) ignored: the block is executed (the skip switch is off)");
    }
    if (block.words_after_semicolon) {
        warnings_.add(
            warning_kind::semicolon_words, line,
            "text after ';' ignored (FANUC reads ';' as end of block; a second block on the same line "
            "is not executed)");
    }
    block_codes c;
    if (auto e = read_codes(block, c)) return e;
    const std::size_t first_out = out.size();
    auto fail = [&](gcode_error e) {
        out.resize(first_out);
        return std::optional<gcode_error>(std::move(e));
    };

    // G04 stands alone (N and comments aside).
    if (c.g_word[g_dwell] != nullptr) {
        const gcode_word& g4 = *c.g_word[g_dwell];
        for (const auto& w : block.words) {
            if (&w == &g4 || &w == c.p || w.letter == 'N') continue;
            return fail(error_at(line, w,
                                 std::string("G04 must be alone in its block (only P may follow), found ") +
                                     w.letter + num(w.value)));
        }
        if (c.p == nullptr) return fail(error_at(line, g4, "G04 needs P (dwell time in ms)"));
        if (c.p->decimal_point || !integral(c.p->value))
            return fail(error_at(line, *c.p, "G04 P is whole milliseconds: no decimal point"));
        if (c.p->value < 0) return fail(error_at(line, *c.p, "negative dwell P" + num(c.p->value)));
        if (c.p->value > max_dwell_ms)
            return fail(error_at(line, *c.p, "dwell P" + num(c.p->value) + " exceeds 99999999 ms"));
        planned_move m;
        m.line = line;
        m.kind = move_kind::dwell;
        m.start = m.end = position_;
        m.dwell_ms = c.p->value;
        out.push_back(m);
        return std::nullopt;
    }
    if (c.p != nullptr) return fail(error_at(line, *c.p, "P is only used with G04"));

    // Modal settings of the block, before its motion.
    if (const auto* w = c.g_word[g_units]) {
        const bool inches = c.g_code[g_units] == 20;
        if (inches != inches_ && moved_) {
            warnings_.add(
                warning_kind::units_switched, line,
                "units switched after motion (FANUC forbids it): the words after it are read in the "
                "new units");
        }
        inches_ = inches;
        (void)w;
    }
    if (c.g_word[g_plane] != nullptr) {
        plane_ = c.g_code[g_plane] == 17 ? arc_plane::xy
                                         : (c.g_code[g_plane] == 18 ? arc_plane::zx : arc_plane::yz);
    }
    if (c.g_word[g_distance] != nullptr) absolute_ = c.g_code[g_distance] == 90;
    if (c.g_word[g_polar] != nullptr) {
        polar_ = c.g_code[g_polar] == 16;
    }
    if (c.f != nullptr) feed_mm_min_ = c.f->value * (inches_ ? mm_per_inch : 1.0);
    if (c.g_word[g_motion] != nullptr) motion_mode_ = c.g_code[g_motion];

    // The analog output (Z in analog mode) before the motion.
    const bool analog = options_.z == z_mode::analog;
    if (analog && c.axis[2] != nullptr) {
        const gcode_word& zw = *c.axis[2];
        const double z = plain_value(zw, inches_ ? 0.0001 : 0.001, inches_ ? "inch" : "mm") *
                         (inches_ ? mm_per_inch : 1.0);
        analog_z_mm_ = absolute_ ? z : analog_z_mm_ + z;
        double v = analog_volts(analog_, analog_z_mm_ * 1000.0);
        if (v < 0 || v > 10) {
            if (options_.analog_range == analog_range_policy::error) {
                return fail(error_at(line, zw,
                                     "Z " + num(analog_z_mm_ * 1000.0) + " um is outside the analog range " +
                                         num(analog_.low_um) + ".." + num(analog_.high_um) + " um"));
            }
            warnings_.add(warning_kind::analog_clamped, line,
                          "Z " + num(analog_z_mm_ * 1000.0) + " um is outside the analog range " +
                              num(analog_.low_um) + ".." + num(analog_.high_um) +
                              " um: the output is clamped to " + (v < 0 ? "0 V" : "10 V"));
            v = v < 0 ? 0 : 10;
        }
        if (!analog_v_ || *analog_v_ != v) {
            planned_move m;
            m.line = line;
            m.kind = move_kind::analog;
            m.start = m.end = position_;
            m.analog_v = v;
            out.push_back(m);
            analog_v_ = v;
        }
    }

    // TTL before the motion of the same block.
    if (c.m_word != nullptr && (c.m_code == 3 || c.m_code == 5)) {
        const bool on = c.m_code == 3;
        if (on != ttl_) {
            planned_move m;
            m.line = line;
            m.kind = move_kind::ttl;
            m.start = m.end = position_;
            m.ttl_on = on;
            out.push_back(m);
            ttl_ = on;
        }
    }

    const bool axis_words = c.axis[0] != nullptr || c.axis[1] != nullptr || (c.axis[2] != nullptr && !analog);
    const bool arc_words =
        c.offset[0] != nullptr || c.offset[1] != nullptr || c.offset[2] != nullptr || c.r != nullptr;
    if (axis_words || arc_words) {
        if (!motion_mode_) {
            const gcode_word* w = nullptr;
            for (const auto& bw : block.words)
                if (w == nullptr && std::string_view("XYZIJKR").find(bw.letter) != std::string_view::npos)
                    w = &bw;
            return fail(error_at(line, *w, "no motion mode: program G00, G01, G02 or G03 before axis words"));
        }
        if (arc_words && *motion_mode_ < 2) {
            const gcode_word* w = c.r;
            for (int i = 2; i >= 0; --i)
                if (c.offset[i] != nullptr) w = c.offset[i];
            return fail(error_at(line, *w, std::string(1, w->letter) + " is only used with G02/G03"));
        }
        if (auto e = motion(block, c, *motion_mode_, out)) return fail(std::move(*e));
    }

    if (c.m_word != nullptr && (c.m_code == 2 || c.m_code == 30)) {
        ended_ = true;
        finish(line, out);
    }
    return std::nullopt;
}

std::optional<gcode_error> gcode_interpreter::motion(const gcode_block& block, const block_codes& c, int mode,
                                                     std::vector<planned_move>& out) {
    const int line = block.line;
    const bool analog = options_.z == z_mode::analog;
    const vec3 start = position_;

    // The end point. Cartesian: each axis word absolute or incremental.
    static constexpr int first_axis[3] = {0, 2, 1};   // polar radius word: xy X, zx Z, yz Y
    static constexpr int second_axis[3] = {1, 0, 2};  // polar angle word: xy Y, zx X, yz Z
    const int plane_index = static_cast<int>(plane_);
    double target[3] = {start.x, start.y, start.z};
    for (int i = 0; i < 3; ++i) {
        if (c.axis[i] == nullptr || (i == 2 && analog)) continue;
        if (polar_ && (i == first_axis[plane_index] || i == second_axis[plane_index])) continue;
        const double v = length(*c.axis[i]);
        target[i] = absolute_ ? v : target[i] + v;
    }
    if (polar_) {
        // Plane's first axis word = radius, second = angle (degrees, CCW from the + first axis).
        // The pole follows the radius word: absolute or omitted -> the work zero, incremental (G91) -> the
        // current position. An omitted radius is the current distance from the work zero; the angle (or,
        // under G91, the angle increment's base) is the current position's angle about the work zero.
        const gcode_word* rw = c.axis[first_axis[plane_index]];
        const gcode_word* aw = c.axis[second_axis[plane_index]];
        if (analog && plane_ != arc_plane::xy) {
            return error_at(line, block.words.front(),
                            "polar coordinates in G18/G19 need the Z axis, which drives the analog output");
        }
        if (rw != nullptr || aw != nullptr) {
            const plane_point s = to_plane(start, plane_);
            const double present_deg = std::atan2(s.b, s.a) * 180 / std::numbers::pi;
            double radius = std::hypot(s.a, s.b);
            double angle_deg = present_deg;
            double pole_a = 0;
            double pole_b = 0;
            if (rw != nullptr) radius = length(*rw);
            if (aw != nullptr) angle_deg = absolute_ ? angle(*aw) : present_deg + angle(*aw);
            if (!absolute_ && rw != nullptr) {
                pole_a = s.a;
                pole_b = s.b;
            }
            const double rad = angle_deg * std::numbers::pi / 180;
            plane_point e = to_plane({target[0], target[1], target[2]}, plane_);
            e.a = pole_a + radius * std::cos(rad);
            e.b = pole_b + radius * std::sin(rad);
            const vec3 v = from_plane(e, plane_);
            target[0] = v.x;
            target[1] = v.y;
            target[2] = v.z;
        }
    }
    const vec3 end{target[0], target[1], target[2]};
    for (double v : target)
        if (!std::isfinite(v)) return error_at(line, block.words.front(), "coordinate out of range");

    planned_move m;
    m.line = line;
    m.start = start;
    m.end = end;

    if (mode <= 1) {
        if (mode == 1 && (!feed_mm_min_ || *feed_mm_min_ <= 0)) {
            return error_at(line, block.words.front(),
                            feed_mm_min_ ? "G01 with zero feed (F0)" : "G01 without a feed: program F first");
        }
        position_ = end;
        // Zero-length moves do nothing and are dropped.
        if (distance(start, end) <= same_point_mm) return std::nullopt;
        m.kind = mode == 0 ? move_kind::rapid : move_kind::linear;
        m.feed_mm_s = mode == 0 ? std::min(options_.rapid_mm_s, options_.max_feed_mm_s) : feed_mm_s(line);
        m.segments = 1;
        out.push_back(m);
        moved_ = true;
        return std::nullopt;
    }

    // G02 / G03.
    const char* const code = mode == 2 ? "G02" : "G03";
    if (!feed_mm_min_ || *feed_mm_min_ <= 0) {
        return error_at(
            line, block.words.front(),
            std::string(code) + (feed_mm_min_ ? " with zero feed (F0)" : " without a feed: program F first"));
    }
    if (analog && plane_ != arc_plane::xy) {
        return error_at(line, block.words.front(),
                        "arcs in G18/G19 need the Z axis, which drives the analog output (z_mode analog)");
    }
    const arc_direction dir = mode == 2 ? arc_direction::cw : arc_direction::ccw;
    const arc_tolerances tol{options_.arc_radius_tolerance_mm, options_.arc_radius_relative_tolerance,
                             options_.arc_r_deficit_tolerance_mm};
    std::variant<arc_geometry, std::string> g;
    if (c.r != nullptr) {
        if (c.offset[0] != nullptr || c.offset[1] != nullptr || c.offset[2] != nullptr) {
            warnings_.add(warning_kind::r_and_ijk, line,
                          "R and I/J/K in one arc block: R is used, I/J/K ignored");
        }
        const plane_point s = to_plane(start, plane_);
        const plane_point e = to_plane(end, plane_);
        if (std::hypot(e.a - s.a, e.b - s.b) <= same_point_mm) {
            if (std::abs(e.n - s.n) > same_point_mm) {
                return error_at(line, *c.r,
                                "R arc whose end equals its start in the plane but moves the third axis: a "
                                "full helix needs I/J/K");
            }
            warnings_.add(
                warning_kind::zero_degree_arc, line,
                "R arc with the end point equal to the start point: a 0-degree arc, no motion (a full "
                "circle needs I/J/K)");
            return std::nullopt;
        }
        g = arc_from_radius(start, end, length(*c.r), plane_, dir, tol);
        if (auto* msg = std::get_if<std::string>(&g)) return error_at(line, *c.r, *msg);
    } else {
        // Offsets per plane in plane order (a, b): G17 (I, J), G18 (K, I), G19 (J, K).
        static constexpr int offset_a[3] = {0, 2, 1};
        static constexpr int offset_b[3] = {1, 0, 2};
        static constexpr int offset_out[3] = {2, 1, 0};
        const int pi = static_cast<int>(plane_);
        if (const auto* w = c.offset[offset_out[pi]]) {
            static constexpr const char* plane_code[3] = {"G17", "G18", "G19"};
            return error_at(line, *w,
                            std::string(1, w->letter) + " is not an arc centre word in " + plane_code[pi] +
                                " (" + to_string(plane_) + " plane)");
        }
        const gcode_word* wa = c.offset[offset_a[pi]];
        const gcode_word* wb = c.offset[offset_b[pi]];
        if (wa == nullptr && wb == nullptr) {
            const gcode_word* w = c.g_word[g_motion] != nullptr ? c.g_word[g_motion] : &block.words.front();
            return error_at(line, *w,
                            std::string(code) + " needs R or the centre words of the plane (" +
                                (plane_ == arc_plane::xy   ? "I, J"
                                 : plane_ == arc_plane::zx ? "K, I"
                                                           : "J, K") +
                                ")");
        }
        const double oa = wa != nullptr ? length(*wa) : 0.0;
        const double ob = wb != nullptr ? length(*wb) : 0.0;
        g = arc_from_center(start, end, oa, ob, plane_, dir, tol);
        if (auto* msg = std::get_if<std::string>(&g)) return error_at(line, wa != nullptr ? *wa : *wb, *msg);
    }
    m.kind = move_kind::arc;
    m.arc = std::get<arc_geometry>(g);
    m.feed_mm_s = feed_mm_s(line);
    m.segments = arc_segment_count(m.arc, options_.arc_tolerance_mm);
    if (m.segments == 0) {
        return error_at(line, block.words.front(),
                        "arc needs more than " + std::to_string(max_arc_segments) +
                            " segments at arc_tolerance_mm " + num(options_.arc_tolerance_mm));
    }
    position_ = end;
    out.push_back(m);
    moved_ = true;
    return std::nullopt;
}

void gcode_interpreter::finish(int line, std::vector<planned_move>& out) {
    if (finished_) return;
    finished_ = true;
    if (!ttl_) return;
    warnings_.add(warning_kind::ttl_on_at_end, line,
                  "TTL still on at the end of the program: switched off (M05 added)");
    planned_move m;
    m.line = line;
    m.kind = move_kind::ttl;
    m.start = m.end = position_;
    m.ttl_on = false;
    out.push_back(m);
    ttl_ = false;
}

}  // namespace gw::gcode
