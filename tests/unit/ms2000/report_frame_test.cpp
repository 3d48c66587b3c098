#include "devices/ms2000/report_frame.hpp"

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gw::devices::ms2000 {
namespace {

using bytes_t = std::vector<std::uint8_t>;

bytes_t text(std::string_view s) {
    return bytes_t(s.begin(), s.end());
}

bytes_t concat(std::initializer_list<bytes_t> parts) {
    bytes_t out;
    for (const bytes_t& p : parts)
        out.insert(out.end(), p.begin(), p.end());
    return out;
}

std::vector<report_frame> decode(report_decoder& d, const bytes_t& bytes) {
    std::vector<report_frame> frames;
    d.feed(bytes, frames);
    return frames;
}

const report_frame xyz{{{'X', 1234}, {'Y', -5}, {'Z', 0}}};

TEST(axis_id, maps_letters_and_ids) {
    const std::string letters = "XYZFTRAB";
    for (std::size_t i = 0; i < letters.size(); ++i) {
        const auto id = static_cast<std::uint8_t>(first_axis_id + i);
        EXPECT_EQ(axis_id(letters[i]), id);
        EXPECT_EQ(axis_id(static_cast<char>(letters[i] - 'A' + 'a')), id);
        EXPECT_EQ(axis_from_id(id), letters[i]);
    }
    EXPECT_EQ(axis_id('X'), 0x18);
    EXPECT_EQ(axis_id('F'), 0x1B);
    EXPECT_EQ(axis_id('Q'), 0);
    EXPECT_EQ(axis_id('\0'), 0);
    EXPECT_EQ(axis_from_id(0x17), '?');
    EXPECT_EQ(axis_from_id(0x20), '?');
    EXPECT_EQ(axis_from_id(0x0D), '?');
}

TEST(encode_report, binary_layout) {
    EXPECT_EQ(encode_report(xyz, report_format::binary),
              (bytes_t{0x18, 0xD2, 0x04, 0x00, 0x00, 0x19, 0xFB, 0xFF, 0xFF, 0xFF, 0x1A, 0, 0, 0, 0, 0x0D}));
    const report_frame extremes{
        {{'X', std::numeric_limits<std::int32_t>::min()}, {'F', std::numeric_limits<std::int32_t>::max()}}};
    EXPECT_EQ(encode_report(extremes, report_format::binary),
              (bytes_t{0x18, 0x00, 0x00, 0x00, 0x80, 0x1B, 0xFF, 0xFF, 0xFF, 0x7F, 0x0D}));
}

TEST(encode_report, ascii_layout) {
    EXPECT_EQ(encode_report(xyz, report_format::ascii), text("X=1234 Y=-5 Z=0\r\n"));
    const report_frame one{{{'z', std::numeric_limits<std::int32_t>::min()}}};
    EXPECT_EQ(encode_report(one, report_format::ascii), text("Z=-2147483648\r\n"));
}

// Frames of 1..8 axes with counts that exercise every byte pattern (0x0D and AIDs inside counts).
std::vector<report_frame> sample_frames() {
    const std::string letters = "XYZFTRAB";
    const std::vector<std::int32_t> counts{0,
                                           1,
                                           -1,
                                           0x0D,
                                           0x0D0D0D0D,
                                           0x18191A1B,
                                           0x1F1F1F1F,
                                           -0x0D0D0D0D,
                                           std::numeric_limits<std::int32_t>::min(),
                                           std::numeric_limits<std::int32_t>::max(),
                                           0x0D18000D};
    std::vector<report_frame> frames;
    for (std::size_t n = 1; n <= report_decoder::max_axes; ++n) {
        for (std::size_t shift = 0; shift < counts.size(); ++shift) {
            report_frame f;
            for (std::size_t i = 0; i < n; ++i)
                f.axes.push_back({letters[i], counts[(i + shift) % counts.size()]});
            frames.push_back(f);
        }
    }
    return frames;
}

class decoder_format_test : public ::testing::TestWithParam<report_format> {};

TEST_P(decoder_format_test, decodes_every_axis_count_in_one_feed) {
    const auto frames = sample_frames();
    bytes_t stream;
    for (const report_frame& f : frames) {
        const bytes_t b = encode_report(f, GetParam());
        stream.insert(stream.end(), b.begin(), b.end());
    }
    report_decoder d(GetParam());
    EXPECT_EQ(decode(d, stream), frames);
    EXPECT_EQ(d.frames_decoded(), frames.size());
    EXPECT_EQ(d.bytes_skipped(), 0u);
    EXPECT_EQ(d.bytes_consumed(), stream.size());
    EXPECT_EQ(d.buffered(), 0u);
}

TEST_P(decoder_format_test, decodes_byte_by_byte) {
    const auto frames = sample_frames();
    report_decoder d(GetParam());
    std::vector<report_frame> out;
    for (const report_frame& f : frames) {
        for (std::uint8_t b : encode_report(f, GetParam()))
            d.feed(std::span<const std::uint8_t>(&b, 1), out);
    }
    EXPECT_EQ(out, frames);
    EXPECT_EQ(d.bytes_skipped(), 0u);
}

TEST_P(decoder_format_test, decodes_at_every_split_point) {
    const report_frame a{{{'X', 0x0D0D0D0D}, {'Y', -1}}};
    const report_frame b{{{'X', 7}, {'Y', std::numeric_limits<std::int32_t>::min()}}};
    const bytes_t stream = concat({encode_report(a, GetParam()), encode_report(b, GetParam())});
    for (std::size_t cut = 0; cut <= stream.size(); ++cut) {
        report_decoder d(GetParam());
        std::vector<report_frame> out;
        d.feed(std::span(stream).first(cut), out);
        d.feed(std::span(stream).subspan(cut), out);
        EXPECT_EQ(out, (std::vector<report_frame>{a, b})) << "cut at " << cut;
        EXPECT_EQ(d.bytes_skipped(), 0u);
    }
}

TEST_P(decoder_format_test, expected_axes_rejects_other_sizes) {
    const report_frame two{{{'X', 1}, {'Y', 2}}};
    const report_frame three{{{'X', 1}, {'Y', 2}, {'Z', 3}}};
    const bytes_t stream = concat(
        {encode_report(two, GetParam()), encode_report(three, GetParam()), encode_report(two, GetParam())});
    report_decoder d(GetParam(), 3);
    EXPECT_EQ(decode(d, stream), std::vector<report_frame>{three});
    EXPECT_GT(d.bytes_skipped(), 0u);
    EXPECT_EQ(d.bytes_skipped() + d.bytes_consumed() + d.buffered(), stream.size());
}

TEST_P(decoder_format_test, reset_drops_a_cut_frame) {
    const bytes_t full = encode_report(xyz, GetParam());
    report_decoder d(GetParam());
    std::vector<report_frame> out;
    d.feed(std::span(full).first(5), out);
    EXPECT_EQ(d.buffered(), 5u);
    d.reset();
    EXPECT_EQ(d.buffered(), 0u);
    EXPECT_EQ(d.bytes_skipped(), 5u);
    d.feed(full, out);
    EXPECT_EQ(out, std::vector<report_frame>{xyz});
}

INSTANTIATE_TEST_SUITE_P(formats, decoder_format_test,
                         ::testing::Values(report_format::binary, report_format::ascii),
                         [](const auto& info) {
                             return info.param == report_format::binary ? "binary" : "ascii";
                         });

TEST(binary_decoder, skips_garbage_between_frames) {
    const bytes_t frame = encode_report(xyz, report_format::binary);
    const bytes_t garbage{0x00, 0xFF, 0x0D, 0x0D, 0x41, 0x20};
    const bytes_t stream = concat({garbage, frame, garbage, frame});
    report_decoder d;
    EXPECT_EQ(decode(d, stream), (std::vector<report_frame>{xyz, xyz}));
    EXPECT_EQ(d.bytes_skipped(), 2 * garbage.size());
    EXPECT_EQ(d.bytes_consumed(), 2 * frame.size());
}

TEST(binary_decoder, resynchronises_after_a_cut_frame) {
    const bytes_t frame = encode_report(xyz, report_format::binary);
    // The first frame loses its tail (the controller reset mid-frame).
    const bytes_t stream = concat({bytes_t(frame.begin(), frame.begin() + 7), frame, frame});
    report_decoder d;
    const auto out = decode(d, stream);
    ASSERT_GE(out.size(), 2u);
    EXPECT_EQ(out.back(), xyz);
    EXPECT_EQ(out[out.size() - 2], xyz);
    EXPECT_EQ(d.bytes_skipped() + d.bytes_consumed() + d.buffered(), stream.size());
    EXPECT_GT(d.bytes_skipped(), 0u);
}

TEST(binary_decoder, count_bytes_equal_to_cr_and_aids) {
    // X count 0x0D0D0D0D, Y count 0x1A1A0D18: structure, not byte values, ends the frame.
    const bytes_t stream{0x18, 0x0D, 0x0D, 0x0D, 0x0D, 0x19, 0x18, 0x0D, 0x1A, 0x1A, 0x0D};
    report_decoder d;
    const auto out = decode(d, stream);
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(out[0], (report_frame{{{'X', 0x0D0D0D0D}, {'Y', 0x1A1A0D18}}}));
    EXPECT_EQ(d.bytes_skipped(), 0u);
}

TEST(binary_decoder, refuses_non_increasing_aids) {
    const bytes_t repeated{0x18, 1, 0, 0, 0, 0x18, 2, 0, 0, 0, 0x0D};
    const bytes_t decreasing{0x19, 1, 0, 0, 0, 0x18, 2, 0, 0, 0, 0x0D};
    for (const bytes_t& stream : {repeated, decreasing}) {
        report_decoder d;
        const auto out = decode(d, stream);
        // Only the trailing single-axis frame "0x18 2 0 0 0 CR" survives the resynchronisation.
        EXPECT_EQ(out, (std::vector<report_frame>{report_frame{{{'X', 2}}}}));
        EXPECT_EQ(d.bytes_skipped(), 5u);
    }
}

TEST(binary_decoder, refuses_an_empty_frame_and_more_than_max_axes) {
    report_decoder d;
    EXPECT_TRUE(decode(d, bytes_t{0x0D, 0x0D}).empty());
    EXPECT_EQ(d.bytes_skipped(), 2u);
    // A ninth AID cannot follow 0x1F: nothing is higher.
    bytes_t nine;
    for (std::uint8_t id = first_axis_id; id <= last_axis_id; ++id)
        nine.insert(nine.end(), {id, 0, 0, 0, 0});
    nine.insert(nine.end(), {0x1F, 0, 0, 0, 0, 0x0D});
    report_decoder e;
    const auto out = decode(e, nine);
    EXPECT_EQ(out, (std::vector<report_frame>{report_frame{{{'B', 0}}}}));
}

TEST(binary_decoder, buffer_stays_bounded) {
    report_decoder d;
    std::vector<report_frame> out;
    const bytes_t noise(10000, 0x18);  // every byte looks like an X AID
    d.feed(noise, out);
    EXPECT_TRUE(out.empty());
    EXPECT_LE(d.buffered(), report_decoder::max_axes * 5 + 1);
    EXPECT_EQ(d.bytes_skipped() + d.buffered(), noise.size());
}

TEST(ascii_decoder, tolerates_missing_lf_and_lf_only) {
    report_decoder d(report_format::ascii);
    const auto out = decode(d, text("X=1 Y=2\rX=3 Y=4\nX=5\r\n"));
    EXPECT_EQ(out, (std::vector<report_frame>{report_frame{{{'X', 1}, {'Y', 2}}},
                                              report_frame{{{'X', 3}, {'Y', 4}}}, report_frame{{{'X', 5}}}}));
    EXPECT_EQ(d.bytes_skipped(), 0u);
}

TEST(ascii_decoder, skips_and_counts_garbage_lines) {
    const std::vector<std::string> garbage{"hello", "X=1 X=2",  "Y=1 X=2", "X=",  "X=1.5", "X=2147483648",
                                           "Q=1",   "X=1 junk", "=5",      "X:1", "X=+1",  ""};
    for (const std::string& g : garbage) {
        report_decoder d(report_format::ascii);
        const bytes_t stream = text(g + "\r\nX=7\r\n");
        EXPECT_EQ(decode(d, stream), (std::vector<report_frame>{report_frame{{{'X', 7}}}})) << g;
        EXPECT_EQ(d.bytes_skipped(), g.size() + 2) << g;
        EXPECT_EQ(d.bytes_consumed(), 5u);
    }
}

TEST(ascii_decoder, overlong_line_is_skipped_to_its_end) {
    report_decoder d(report_format::ascii);
    const std::string noise(report_decoder::max_ascii_line_bytes * 3, 'X');
    const bytes_t stream = text(noise + "\r\nZ=-1\r\n");
    EXPECT_EQ(decode(d, stream), (std::vector<report_frame>{report_frame{{{'Z', -1}}}}));
    EXPECT_EQ(d.bytes_skipped(), noise.size() + 2);
    EXPECT_LE(d.buffered(), report_decoder::max_ascii_line_bytes);
}

}  // namespace

// Readable failure messages (found by ADL, so outside the unnamed namespace).
void PrintTo(const report_frame& f, std::ostream* os) {
    for (const axis_count& a : f.axes)
        *os << a.axis << '=' << a.count << ' ';
}

}  // namespace gw::devices::ms2000
