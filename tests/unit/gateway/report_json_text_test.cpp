// report_json_text writes a report frame's JSON by hand: each row checks it against the value the
// same frame has as a nlohmann DOM, and the text details that a DOM comparison cannot see.
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gateway/events/event_json.hpp"

namespace {

using nlohmann::json;
using axis = gw::devices::report_event::axis;

gw::devices::report_event frame(std::vector<axis> axes) {
    gw::devices::report_event e;
    e.controller_id = "stage-1_a";
    e.sequence = 42;
    e.bytes_skipped = 5;
    e.system_time = std::chrono::system_clock::time_point(std::chrono::milliseconds(1795322740456));
    e.axes = std::move(axes);
    return e;
}

json expected(const json& axes) {
    return {{"id", "stage-1_a"},
            {"controller_seq", 42},
            {"bytes_skipped", 5},
            {"time", "2026-11-22T04:45:40.456Z"},
            {"axes", axes}};
}

struct row {
    const char* what;
    std::vector<axis> axes;
    json axes_json;
};

TEST(report_json_text, reads_back_as_the_frame_in_every_row) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const std::vector<row> rows = {
        {"no axes", {}, json::array()},
        {"one axis, position known",
         {{'X', 12345, 271.937}},
         {{{"axis", "X"}, {"counts", 12345}, {"position_um", 271.937}}}},
        {"position unknown",
         {{'Y', -20, std::nullopt}},
         {{{"axis", "Y"}, {"counts", -20}, {"position_um", nullptr}}}},
        {"rounded to the nanometre",
         {{'Z', 1, 0.1 + 0.2}},
         {{{"axis", "Z"}, {"counts", 1}, {"position_um", 0.3}}}},
        {"a few nanometres below zero",
         {{'X', -1, -0.004}},
         {{{"axis", "X"}, {"counts", -1}, {"position_um", -0.004}}}},
        {"extreme counts",
         {{'X', std::numeric_limits<std::int32_t>::min(), -1e9},
          {'Y', std::numeric_limits<std::int32_t>::max(), 1e9}},
         {{{"axis", "X"}, {"counts", std::numeric_limits<std::int32_t>::min()}, {"position_um", -1e9}},
          {{"axis", "Y"}, {"counts", std::numeric_limits<std::int32_t>::max()}, {"position_um", 1e9}}}},
        {"not a number", {{'X', 0, nan}}, {{{"axis", "X"}, {"counts", 0}, {"position_um", nullptr}}}},
    };
    for (const auto& r : rows) {
        const auto text = gw::report_json_text(frame(r.axes));
        ASSERT_TRUE(json::accept(text)) << r.what << ": " << text;
        EXPECT_EQ(json::parse(text), expected(r.axes_json)) << r.what << ": " << text;
    }
}

TEST(report_json_text, keeps_the_key_order_and_number_forms_of_the_other_events) {
    EXPECT_EQ(
        gw::report_json_text(frame({{'X', 7, 5.0}, {'Y', 8, 1234.5}})),
        R"({"axes":[{"axis":"X","counts":7,"position_um":5.0},{"axis":"Y","counts":8,"position_um":1234.5}],)"
        R"("bytes_skipped":5,"controller_seq":42,"id":"stage-1_a","time":"2026-11-22T04:45:40.456Z"})");
}

TEST(report_json_text, escapes_what_a_json_string_cannot_hold) {
    auto e = frame({{'"', 1, std::nullopt}, {'\n', 2, std::nullopt}});
    e.controller_id = "a\"b\\c";
    const auto j = json::parse(gw::report_json_text(e));
    EXPECT_EQ(j["id"], "a\"b\\c");
    EXPECT_EQ(j["axes"][0]["axis"], "?") << "no axis letter: not written as is";
    EXPECT_EQ(j["axes"][1]["axis"], "?");
}

}  // namespace
