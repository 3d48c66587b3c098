#include "gateway/jobs/kinds/scan_spec.hpp"

#include <cctype>
#include <cmath>
#include <fmt/format.h>

#include "gateway/controllers/operations.hpp"
#include "gateway/jobs/kinds/spec_fields.hpp"

namespace gw::jobs {

namespace {

using json = nlohmann::json;

operation_result<char> axis_letter(const json& v, const std::string& field) {
    if (!v.is_string() || v.get<std::string>().size() != 1 ||
        !std::isalpha(static_cast<unsigned char>(v.get<std::string>()[0])))
        return spec_error(field, fmt::format("{} must be one axis letter (\"X\")", field));
    return static_cast<char>(std::toupper(static_cast<unsigned char>(v.get<std::string>()[0])));
}

}  // namespace

double scan_geometry::line_length_mm() const {
    return std::abs(fast_stop_mm - fast_start_mm);
}

double scan_geometry::slow_step_mm() const {
    return lines > 1 ? (slow_stop_mm - slow_start_mm) / (lines - 1) : 0;
}

double scan_geometry::slow_at(int line) const {
    return slow_start_mm + line * slow_step_mm();
}

double scan_geometry::fast_begin(int line) const {
    return serpentine && line % 2 == 1 ? fast_stop_mm : fast_start_mm;
}

double scan_geometry::fast_end(int line) const {
    return serpentine && line % 2 == 1 ? fast_start_mm : fast_stop_mm;
}

operation_result<scan_spec> parse_scan_spec(const json& spec) {
    if (!spec.is_object())
        return make_error(operation_error_kind::invalid_value, "spec must be an object", "spec");
    if (auto k = spec_known_fields(
            spec, "", {"fast_axis", "slow_axis", "fast", "slow", "pattern", "speed_mm_s", "mode", "record"});
        !k)
        return k.error();
    scan_spec s;
    if (spec.contains("fast_axis")) {
        auto a = axis_letter(spec["fast_axis"], "fast_axis");
        if (!a) return a.error();
        s.fast_axis = *a;
    }
    if (spec.contains("slow_axis")) {
        auto a = axis_letter(spec["slow_axis"], "slow_axis");
        if (!a) return a.error();
        s.slow_axis = *a;
    }
    if (s.fast_axis == s.slow_axis) return spec_error("slow_axis", "slow_axis must differ from fast_axis");

    if (!spec.contains("fast"))
        return spec_error("fast", "fast {start_mm, stop_mm | pixels, encoder_divide} is required");
    const auto& fast = spec["fast"];
    if (!fast.is_object())
        return spec_error("fast", "fast must be an object {start_mm, stop_mm | pixels, encoder_divide}");
    if (auto k = spec_known_fields(fast, "fast.", {"start_mm", "stop_mm", "pixels", "encoder_divide"}); !k)
        return k.error();
    if (fast.contains("start_mm")) {
        auto v = spec_number(fast["start_mm"], "fast.start_mm", -max_scan_extent_mm, max_scan_extent_mm);
        if (!v) return v.error();
        s.fast_start_mm = *v;
    }
    if (fast.contains("stop_mm") == fast.contains("pixels"))
        return spec_error(fast.contains("pixels") ? "fast.pixels" : "fast.stop_mm",
                          "give exactly one of fast.stop_mm and fast.pixels");
    if (fast.contains("stop_mm")) {
        auto v = spec_number(fast["stop_mm"], "fast.stop_mm", -max_scan_extent_mm, max_scan_extent_mm);
        if (!v) return v.error();
        if (*v == s.fast_start_mm)
            return spec_error("fast.stop_mm", "fast.stop_mm must differ from fast.start_mm");
        s.fast_stop_mm = *v;
    } else {
        // The SCAN module's own limit is checked with the geometry; here only the type and sign.
        auto v = spec_integer(fast["pixels"], "fast.pixels", 1, 1'000'000'000);
        if (!v) return v.error();
        s.pixels = *v;
    }
    if (fast.contains("encoder_divide")) {
        auto v = spec_integer(fast["encoder_divide"], "fast.encoder_divide", 1, 1'000'000'000);
        if (!v) return v.error();
        s.encoder_divide = *v;
    }

    if (!spec.contains("slow")) return spec_error("slow", "slow {start_mm, stop_mm, lines} is required");
    const auto& slow = spec["slow"];
    if (!slow.is_object()) return spec_error("slow", "slow must be an object {start_mm, stop_mm, lines}");
    if (auto k = spec_known_fields(slow, "slow.", {"start_mm", "stop_mm", "lines"}); !k) return k.error();
    if (slow.contains("start_mm")) {
        auto v = spec_number(slow["start_mm"], "slow.start_mm", -max_scan_extent_mm, max_scan_extent_mm);
        if (!v) return v.error();
        s.slow_start_mm = *v;
    }
    if (!slow.contains("lines")) return spec_error("slow.lines", "slow.lines is required");
    auto lines = spec_integer(slow["lines"], "slow.lines", 1, scan_firmware_limit - 1);
    if (!lines) return lines.error();
    s.lines = *lines;
    if (slow.contains("stop_mm")) {
        auto v = spec_number(slow["stop_mm"], "slow.stop_mm", -max_scan_extent_mm, max_scan_extent_mm);
        if (!v) return v.error();
        s.slow_stop_mm = *v;
    } else if (s.lines == 1) {
        s.slow_stop_mm = s.slow_start_mm;
    } else {
        return spec_error("slow.stop_mm", "slow.stop_mm is required with more than one line");
    }
    if (s.lines > 1 && s.slow_stop_mm == s.slow_start_mm)
        return spec_error("slow.stop_mm",
                          "slow.stop_mm must differ from slow.start_mm with more than one line");

    if (spec.contains("pattern")) {
        const auto& p = spec["pattern"];
        if (p == "raster")
            s.serpentine = false;
        else if (p == "serpentine")
            s.serpentine = true;
        else
            return spec_error("pattern", "pattern must be \"raster\" or \"serpentine\"");
    }
    if (spec.contains("speed_mm_s")) {
        auto v = spec_number(spec["speed_mm_s"], "speed_mm_s", 0, max_speed_mm_s);
        if (!v) return v.error();
        if (*v <= 0) return spec_error("speed_mm_s", "speed_mm_s must be above 0");
        s.speed_mm_s = *v;
    }
    if (spec.contains("mode")) {
        const auto& m = spec["mode"];
        if (m == "auto")
            s.mode = scan_spec::path_mode::automatic;
        else if (m == "firmware")
            s.mode = scan_spec::path_mode::firmware;
        else if (m == "host")
            s.mode = scan_spec::path_mode::host;
        else
            return spec_error("mode", "mode must be \"auto\", \"firmware\" or \"host\"");
    }
    return s;
}

operation_result<scan_geometry> scan_firmware_geometry(const scan_spec& spec, double counts_per_mm) {
    if (!(counts_per_mm > 0) || !std::isfinite(counts_per_mm))
        return make_error(operation_error_kind::internal,
                          fmt::format("encoder counts per mm of axis {} unknown", spec.fast_axis));
    if (spec.encoder_divide >= scan_firmware_limit)
        return spec_error(
            "fast.encoder_divide",
            fmt::format("fast.encoder_divide {} is too large: the SCAN module needs it below {}",
                        spec.encoder_divide, scan_firmware_limit));
    scan_geometry g;
    g.counts_per_mm = counts_per_mm;
    g.fast_start_mm = spec.fast_start_mm;
    g.slow_start_mm = spec.slow_start_mm;
    g.slow_stop_mm = spec.slow_stop_mm;
    g.lines = spec.lines;
    g.serpentine = spec.serpentine;
    if (spec.pixels) {
        if (*spec.pixels >= scan_firmware_limit)
            return spec_error("fast.pixels",
                              fmt::format("fast.pixels {} is too many: the SCAN module needs fewer than {}",
                                          *spec.pixels, scan_firmware_limit));
        g.pixels = *spec.pixels;
        g.line_counts = static_cast<long long>(g.pixels) * spec.encoder_divide;
        g.fast_stop_mm = spec.fast_start_mm + static_cast<double>(g.line_counts) / counts_per_mm;
        if (std::abs(g.fast_stop_mm) > max_scan_extent_mm)
            return spec_error("fast.pixels",
                              fmt::format("{} pixels of {} counts end at {:.3f} mm, beyond +-{} mm", g.pixels,
                                          spec.encoder_divide, g.fast_stop_mm, max_scan_extent_mm));
        return g;
    }
    g.fast_stop_mm = *spec.fast_stop_mm;
    g.line_counts = std::llround(std::abs(g.fast_stop_mm - g.fast_start_mm) * counts_per_mm);
    const long long pixels = g.line_counts / spec.encoder_divide;
    if (pixels >= scan_firmware_limit)
        return spec_error(
            "fast.stop_mm",
            fmt::format("the line from {} to {} mm is {} encoder counts = {} pixels of {} counts: the SCAN "
                        "module needs fewer than {} pixels (raise fast.encoder_divide or shorten the line)",
                        g.fast_start_mm, g.fast_stop_mm, g.line_counts, pixels, spec.encoder_divide,
                        scan_firmware_limit));
    if (pixels < 1)
        return spec_error("fast.stop_mm",
                          fmt::format("the line from {} to {} mm is {} encoder counts, shorter than one "
                                      "pixel of {} counts",
                                      g.fast_start_mm, g.fast_stop_mm, g.line_counts, spec.encoder_divide));
    g.pixels = static_cast<int>(pixels);
    return g;
}

}  // namespace gw::jobs
