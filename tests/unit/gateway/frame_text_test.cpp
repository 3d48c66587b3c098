// The text forms of a recording's rows (gateway/recordings/frame_text): CSV and JSON Lines, one row
// per frame or marker, the same columns in both.

#include "gateway/recordings/frame_text.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace gw::recordings {
namespace {

recording_record two_axes() {
    recording_record r;
    r.id = "r-1";
    r.axes = "XY";
    return r;
}

recorded_frame frame(std::uint64_t index, std::vector<std::int32_t> counts,
                     std::vector<std::optional<double>> um) {
    recorded_frame f;
    f.index = index;
    f.time_us = 1'765'000'000'000'000 + static_cast<std::int64_t>(index);
    f.counts = std::move(counts);
    f.um = std::move(um);
    return f;
}

recorded_frame marker(std::uint64_t index, loss_kind kind) {
    recorded_frame m;
    m.index = index;
    m.time_us = 42;
    m.loss = kind;
    return m;
}

TEST(FrameText, ColumnsFollowTheAxesMicrometresFirst) {
    EXPECT_EQ(frame_columns(two_axes()),
              (std::vector<std::string>{"index", "time_us", "loss", "X_um", "Y_um", "X_counts", "Y_counts"}));
    EXPECT_EQ(csv_header(two_axes()), "index,time_us,loss,X_um,Y_um,X_counts,Y_counts\n");
    recording_record none;
    EXPECT_EQ(csv_header(none), "index,time_us,loss\n");
}

TEST(FrameText, CsvRowsFramesAndMarkers) {
    std::vector<recorded_frame> rows{frame(0, {20010, -400}, {1000.5, -20.0}), marker(1, loss_kind::garbled),
                                     frame(1, {7, 8}, {std::nullopt, 0.25})};
    std::string out;
    append_rows(frame_format::csv, two_axes(), rows, out);
    EXPECT_EQ(out,
              "0,1765000000000000,,1000.5,-20,20010,-400\n"
              "1,42,garbled,,,,\n"
              "1,1765000000000001,,,0.25,7,8\n");
}

TEST(FrameText, JsonLinesHaveTheCsvColumnsAsKeys) {
    std::vector<recorded_frame> rows{frame(3, {20010, -400}, {1000.5, std::nullopt}),
                                     marker(4, loss_kind::overrun)};
    std::string out;
    append_rows(frame_format::jsonl, two_axes(), rows, out);
    const auto newline = out.find('\n');
    ASSERT_NE(newline, std::string::npos);
    auto first = nlohmann::json::parse(out.substr(0, newline));
    auto second = nlohmann::json::parse(out.substr(newline + 1));
    EXPECT_EQ(first["index"], 3);
    EXPECT_TRUE(first["loss"].is_null());
    EXPECT_EQ(first["X_um"], 1000.5);
    EXPECT_TRUE(first["Y_um"].is_null());
    EXPECT_EQ(first["Y_counts"], -400);
    EXPECT_EQ(second["loss"], "overrun");
    EXPECT_TRUE(second["X_counts"].is_null());
    const auto ordered = nlohmann::ordered_json::parse(out.substr(0, newline));
    std::vector<std::string> keys;
    for (auto it = ordered.begin(); it != ordered.end(); ++it)
        keys.push_back(it.key());
    EXPECT_EQ(keys, frame_columns(two_axes()));
}

TEST(FrameText, AFrameWithFewerValuesThanAxesLeavesTheRestEmpty) {
    std::vector<recorded_frame> rows{frame(0, {5}, {1.0})};
    std::string out;
    append_rows(frame_format::csv, two_axes(), rows, out);
    EXPECT_EQ(out, "0,1765000000000000,,1,,5,\n");
}

}  // namespace
}  // namespace gw::recordings
