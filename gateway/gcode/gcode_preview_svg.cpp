#include "gateway/gcode/gcode_preview_svg.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <variant>

#include "gateway/gcode/gcode_arc.hpp"
#include "gateway/gcode/gcode_plan_json.hpp"

namespace gw::gcode {

namespace {

constexpr std::size_t points_per_path = 1000;  // long runs are split: no megabyte-long attribute

const char* class_name(int s) {
    switch (s) {
        case 1:
            return "feed";
        case 2:
            return "rapid";
        case 3:
            return "ttl";
        default:
            return "";
    }
}

std::string px(double v) {
    return trimmed_fixed(v, 2);
}

std::optional<double> parse_number(const std::string& text) {
    double v = 0;
    const char* end = text.data() + text.size();
    auto [ptr, ec] = std::from_chars(text.data(), end, v);
    if (ec != std::errc{} || ptr != end || !std::isfinite(v)) return std::nullopt;
    return v;
}

const char* axis_names(arc_plane view) {
    switch (view) {
        case arc_plane::zx:
            return "Z right, X up";
        case arc_plane::yz:
            return "Y right, Z up";
        case arc_plane::xy:
            break;
    }
    return "X right, Y up";
}

}  // namespace

preview_option_result set_preview_option(preview_options& o, const std::string& name,
                                         const std::string& value) {
    preview_option_result r;
    if (name == "view") {
        r.known = true;
        if (value == "XY" || value == "xy")
            o.view = arc_plane::xy;
        else if (value == "ZX" || value == "zx")
            o.view = arc_plane::zx;
        else if (value == "YZ" || value == "yz")
            o.view = arc_plane::yz;
        else
            r.error = "view must be XY, ZX or YZ";
    } else if (name == "width_px") {
        r.known = true;
        auto v = parse_number(value);
        if (!v || *v < 50 || *v > 10000)
            r.error = "width_px must be a number from 50 to 10000";
        else
            o.width_px = *v;
    } else if (name == "max_points") {
        r.known = true;
        auto v = parse_number(value);
        if (!v || *v < 100 || *v > 1'000'000 || *v != std::floor(*v))
            r.error = "max_points must be a whole number from 100 to 1000000";
        else
            o.max_points = static_cast<std::size_t>(*v);
    }
    return r;
}

preview_svg_writer::preview_svg_writer(std::ostream& out, const plan_summary& summary,
                                       const preview_options& options)
    : out_(out), options_(options), summary_(summary) {
    const plane_point lo = to_plane(summary.min, options.view);
    const plane_point hi = to_plane(summary.max, options.view);
    const double ext_h = std::max(0.0, hi.a - lo.a);
    const double ext_v = std::max(0.0, hi.b - lo.b);
    double extent = std::max(ext_h, ext_v);
    if (!(extent > 0)) extent = 1;  // a single point or nothing: 1 mm across
    margin_px_ = std::clamp(options.width_px / 80, 2.0, 20.0);
    scale_ = (options.width_px - 2 * margin_px_) / extent;
    origin_h_ = lo.a;
    top_v_ = hi.b;
    const std::uint64_t segments = std::max<std::uint64_t>(summary.segments, 1);
    stride_ = (segments + options.max_points - 1) / options.max_points;
    if (stride_ < 1) stride_ = 1;

    const double w = ext_h * scale_ + 2 * margin_px_;
    const double h = ext_v * scale_ + 2 * margin_px_;
    out_ << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << px(w) << "\" height=\"" << px(h)
         << "\" viewBox=\"0 0 " << px(w) << ' ' << px(h) << "\">\n"
         << "<title>G-code plan, " << axis_names(options.view) << ", " << px(1 / scale_ * 1000)
         << " um per pixel</title>\n"
         << "<style>path{fill:none;stroke-linejoin:round;stroke-linecap:round}"
            ".feed{stroke:#1f5fbf;stroke-width:1}"
            ".rapid{stroke:#8c8c8c;stroke-width:1;stroke-dasharray:4 3}"
            ".ttl{stroke:#d62728;stroke-width:2}"
            ".start{fill:#2ca02c}</style>\n";
    const pixel start = to_pixel(vec3{});
    out_ << "<circle class=\"start\" cx=\"" << px(start.x) << "\" cy=\"" << px(start.y) << "\" r=\"3\"/>\n";
    last_ = start;
}

preview_svg_writer::pixel preview_svg_writer::to_pixel(const vec3& p) const {
    const plane_point q = to_plane(p, options_.view);
    return {(q.a - origin_h_) * scale_ + margin_px_, (top_v_ - q.b) * scale_ + margin_px_};
}

void preview_svg_writer::write_point(char command, const pixel& p) {
    out_ << command << px(p.x) << ' ' << px(p.y);
    last_ = p;
    ++points_;
    ++path_points_;
}

void preview_svg_writer::close_path() {
    if (current_ == style::none) return;
    if (has_pending_ && !truncated_) write_point('L', pending_);
    has_pending_ = false;
    out_ << "\"/>\n";
    current_ = style::none;
}

void preview_svg_writer::draw_to(const vec3& p, style s) {
    if (truncated_) return;
    if (points_ >= 2 * options_.max_points) {
        close_path();
        truncated_ = true;
        return;
    }
    if (s != current_) {
        close_path();
        const pixel from = last_;
        out_ << "<path class=\"" << class_name(static_cast<int>(s)) << "\" d=\"";
        current_ = s;
        path_points_ = 0;
        write_point('M', from);
        since_drawn_ = 0;
    } else if (path_points_ >= points_per_path) {
        const pixel from = has_pending_ ? pending_ : last_;
        if (has_pending_) write_point('L', pending_);
        has_pending_ = false;
        out_ << "\"/>\n<path class=\"" << class_name(static_cast<int>(s)) << "\" d=\"";
        path_points_ = 0;
        write_point('M', from);
    }
    const pixel q = to_pixel(p);
    ++since_drawn_;
    const bool close = std::hypot(q.x - last_.x, q.y - last_.y) < min_step_px_;
    if (close || since_drawn_ < stride_) {
        pending_ = q;
        has_pending_ = true;
        return;
    }
    write_point('L', q);
    has_pending_ = false;
    since_drawn_ = 0;
}

void preview_svg_writer::on_move(const planned_move& m) {
    switch (m.kind) {
        case move_kind::ttl:
            ttl_on_ = m.ttl_on;
            return;
        case move_kind::dwell:
        case move_kind::analog:
            return;
        case move_kind::rapid:
        case move_kind::linear:
        case move_kind::arc:
            break;
    }
    const style s = ttl_on_ ? style::ttl : m.kind == move_kind::rapid ? style::rapid : style::feed;
    if (m.kind != move_kind::arc) return draw_to(m.end, s);
    // Half a pixel of chord error is invisible; never more points than the machine's segments.
    std::uint64_t n = arc_segment_count(m.arc, 0.5 / scale_);
    if (n == 0 || n > m.segments) n = m.segments;
    n = std::max<std::uint64_t>(n, 1);
    for (std::uint64_t i = 1; i <= n && !truncated_; ++i)
        draw_to(i == n ? m.end : arc_point(m.arc, static_cast<double>(i) / static_cast<double>(n)), s);
}

void preview_svg_writer::finish() {
    close_path();
    out_ << "<desc>moves " << summary_.moves << ", segments " << summary_.segments << ", drawn points "
         << points_ << " (at most every " << stride_ << (stride_ == 1 ? "st" : "th") << " point), estimated "
         << px(summary_.estimated_s) << " s" << (truncated_ ? ", truncated" : "") << "</desc>\n</svg>\n";
}

std::optional<gcode_error> write_preview_svg(std::istream& in, const gcode_options& options,
                                             const preview_options& view, std::ostream& out) {
    const auto start = in.tellg();
    auto checked = check_program(in, options);
    if (auto* e = std::get_if<gcode_error>(&checked)) return *e;
    if (start == std::istream::pos_type(-1))
        return gcode_error{0, 0, "the preview needs a program it can read twice (a file or a request body)"};
    in.clear();
    in.seekg(start);
    preview_svg_writer writer(out, std::get<plan_summary>(checked), view);
    auto planned = plan_program(in, options, writer);
    if (auto* e = std::get_if<gcode_error>(&planned)) return *e;  // the stream changed between passes
    writer.finish();
    return std::nullopt;
}

}  // namespace gw::gcode
