#include "devices/ms2000/report_frame.hpp"

#include <algorithm>
#include <charconv>
#include <optional>
#include <string_view>

#include "devices/ms2000/ascii.hpp"

namespace gw::devices::ms2000 {

namespace {

// 0x18..0x1B are ASI's (seed 003); 0x1C T and 0x1D R follow the CMDs order "XYZFTR". 0x1E and 0x1F
// are our choice ("A", "B"), so that every AID the decoder accepts has a letter. [U]
constexpr std::string_view axis_letters = "XYZFTRAB";
constexpr std::uint8_t frame_end = 0x0D;
constexpr std::size_t bytes_per_axis = 5;

enum class scan_result : std::uint8_t { frame, incomplete, invalid };

}  // namespace

char axis_from_id(std::uint8_t id) {
    if (id < first_axis_id || id > last_axis_id) return '?';
    return axis_letters[id - first_axis_id];
}

std::uint8_t axis_id(char axis) {
    const auto pos = axis_letters.find(ascii_upper(axis));
    if (axis == '\0' || pos == std::string_view::npos) return 0;
    return static_cast<std::uint8_t>(first_axis_id + pos);
}

std::vector<std::uint8_t> encode_report(const report_frame& frame, report_format format) {
    std::vector<std::uint8_t> out;
    if (format == report_format::binary) {
        // AID LSB MB MSB HB per axis, then CR. Axes without an id are left out.
        for (const axis_count& a : frame.axes) {
            const std::uint8_t id = axis_id(a.axis);
            if (id == 0) continue;
            const auto value = static_cast<std::uint32_t>(a.count);
            out.push_back(id);
            for (int shift = 0; shift < 32; shift += 8)
                out.push_back(static_cast<std::uint8_t>(value >> shift));
        }
        out.push_back(frame_end);
        return out;
    }
    // "X=1234 Y=-5 Z=0\r\n"
    std::string text;
    for (const axis_count& a : frame.axes) {
        if (axis_id(a.axis) == 0) continue;
        if (!text.empty()) text.push_back(' ');
        text.push_back(ascii_upper(a.axis));
        text.push_back('=');
        text += std::to_string(a.count);
    }
    text += "\r\n";
    out.assign(text.begin(), text.end());
    return out;
}

report_decoder::report_decoder(report_format format, std::size_t expected_axes)
    : format_(format), expected_axes_(expected_axes) {}

void report_decoder::reset() {
    bytes_skipped_ += pending_.size();
    pending_.clear();
    after_cr_ = after_cr::nothing;
    discarding_ = false;
}

void report_decoder::feed(std::span<const std::uint8_t> bytes, std::vector<report_frame>& frames) {
    if (format_ == report_format::binary) {
        feed_binary(bytes, frames);
    } else {
        feed_ascii(bytes, frames);
    }
}

bool report_decoder::accept(const report_frame& frame) const {
    if (frame.axes.empty() || frame.axes.size() > max_axes) return false;
    return expected_axes_ == 0 || frame.axes.size() == expected_axes_;
}

namespace {

// Reads one binary frame at the start of `data`. The structure decides, never a length: an AID, four
// count bytes (any value, 0x0D included), then CR or a strictly higher AID.
scan_result scan_binary(std::span<const std::uint8_t> data, std::size_t expected_axes, report_frame& frame,
                        std::size_t& used) {
    frame.axes.clear();
    const std::size_t limit = expected_axes == 0 ? report_decoder::max_axes : expected_axes;
    std::size_t i = 0;
    int previous_id = -1;
    while (true) {
        if (i >= data.size()) return scan_result::incomplete;
        const std::uint8_t b = data[i];
        if (b == frame_end && !frame.axes.empty()) {
            if (expected_axes != 0 && frame.axes.size() != expected_axes) return scan_result::invalid;
            used = i + 1;
            return scan_result::frame;
        }
        if (b < first_axis_id || b > last_axis_id || b <= previous_id || frame.axes.size() >= limit) {
            return scan_result::invalid;
        }
        if (data.size() - i < bytes_per_axis) return scan_result::incomplete;
        std::uint32_t value = 0;
        for (std::size_t k = 0; k < 4; ++k)
            value |= static_cast<std::uint32_t>(data[i + 1 + k]) << (8 * k);
        frame.axes.push_back({axis_from_id(b), static_cast<std::int32_t>(value)});
        previous_id = b;
        i += bytes_per_axis;
    }
}

// "X=1234 Y=-5 Z=0" (no terminator). Letters must have AIDs and strictly increase in AID order.
std::optional<report_frame> parse_ascii(std::string_view line) {
    report_frame frame;
    int previous_id = -1;
    while (!line.empty()) {
        const auto start = line.find_first_not_of(' ');
        if (start == std::string_view::npos) break;
        line.remove_prefix(start);
        const auto end = std::min(line.find(' '), line.size());
        const std::string_view token = line.substr(0, end);
        line.remove_prefix(end);
        if (token.size() < 3 || token[1] != '=') return std::nullopt;
        const std::uint8_t id = axis_id(token[0]);
        if (id == 0 || id <= previous_id) return std::nullopt;
        std::int32_t count = 0;
        const std::string_view digits = token.substr(2);
        const auto [ptr, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), count);
        if (ec != std::errc{} || ptr != digits.data() + digits.size()) return std::nullopt;
        frame.axes.push_back({axis_from_id(id), count});
        previous_id = id;
    }
    return frame;
}

}  // namespace

void report_decoder::feed_binary(std::span<const std::uint8_t> bytes, std::vector<report_frame>& frames) {
    pending_.insert(pending_.end(), bytes.begin(), bytes.end());
    std::size_t pos = 0;
    report_frame frame;
    while (pos < pending_.size()) {
        std::size_t used = 0;
        const auto result =
            scan_binary(std::span<const std::uint8_t>(pending_).subspan(pos), expected_axes_, frame, used);
        if (result == scan_result::incomplete) break;
        if (result == scan_result::invalid) {
            // Skip one byte and scan again from the next: a frame may start inside what was rejected.
            ++bytes_skipped_;
            ++pos;
            continue;
        }
        frames.push_back(frame);
        ++frames_decoded_;
        bytes_consumed_ += used;
        pos += used;
    }
    pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(pos));
}

void report_decoder::feed_ascii(std::span<const std::uint8_t> bytes, std::vector<report_frame>& frames) {
    for (const std::uint8_t b : bytes) {
        if (b == '\n' && after_cr_ != after_cr::nothing) {
            // The LF of a CR LF: part of the frame before it, or of the garbage before it.
            (after_cr_ == after_cr::frame ? bytes_consumed_ : bytes_skipped_) += 1;
            after_cr_ = after_cr::nothing;
            continue;
        }
        const bool cr = b == '\r';
        after_cr_ = after_cr::nothing;
        if (discarding_) {
            ++bytes_skipped_;
            if (cr || b == '\n') {
                discarding_ = false;
                if (cr) after_cr_ = after_cr::garbage;
            }
            continue;
        }
        if (!cr && b != '\n') {
            pending_.push_back(b);
            if (pending_.size() > max_ascii_line_bytes) {
                // Too long to be a frame: skip it all, up to the end of the line.
                bytes_skipped_ += pending_.size();
                pending_.clear();
                discarding_ = true;
            }
            continue;
        }
        // End of a line: CR (a missing LF is tolerated) or LF alone.
        const std::string_view line(reinterpret_cast<const char*>(pending_.data()), pending_.size());
        const auto frame = parse_ascii(line);
        const std::size_t size = pending_.size() + 1;
        pending_.clear();
        if (frame && accept(*frame)) {
            frames.push_back(*frame);
            ++frames_decoded_;
            bytes_consumed_ += size;
            if (cr) after_cr_ = after_cr::frame;
        } else {
            bytes_skipped_ += size;
            if (cr) after_cr_ = after_cr::garbage;
        }
    }
}

}  // namespace gw::devices::ms2000
