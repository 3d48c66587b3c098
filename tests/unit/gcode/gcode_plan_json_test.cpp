#include "gateway/gcode/gcode_plan_json.hpp"

#include <sstream>
#include <streambuf>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace gw::gcode {
namespace {

std::string plan_text(const std::string& program, const gcode_options& o = {}, bool* ok = nullptr) {
    std::istringstream in(program);
    std::ostringstream out;
    const bool r = write_plan_json(in, o, out);
    if (ok != nullptr) *ok = r;
    return out.str();
}

TEST(plan_json, exact_document_for_a_line) {
    // 1 mm at 1 mm/s: 1 s + 20 ms ramp + 14 ms settle; on a 100000 baud line with no turnaround and
    // no poll interval, SPEED (27 + 1 + 2 + 2 characters: 3.2 ms), MOVE (26: 2.6 ms) and the STATUS
    // that notices the stop (5: 0.5 ms, half a 0.5 ms cycle before it: 0.75 ms): 6.55 ms.
    gcode_options o;
    o.host = {100000, 0, 0};
    EXPECT_EQ(plan_text("G01 X1. F60\n", o),
              R"({"units":"mm","moves":[{"line":1,"kind":"linear","end":[1,0,0],"feed_mm_s":1}],)"
              R"("segments":1,"estimated_s":1.04055,"bounds":{"min":[0,0,0],"max":[1,0,0]},"warnings":[]})");
}

TEST(plan_json, every_kind_has_its_fields) {
    gcode_options o;
    o.z = z_mode::analog;
    bool ok = false;
    const auto text = plan_text("G00 X-1.5\nG02 X8.5 Y0 I5. F120 M03\nG04 P250\nZ.05\nM05\n", o, &ok);
    ASSERT_TRUE(ok) << text;
    const auto j = nlohmann::json::parse(text);
    EXPECT_EQ(j["units"], "mm");
    const auto& m = j["moves"];
    ASSERT_EQ(m.size(), 6u);
    EXPECT_EQ(m[0], nlohmann::json::parse(R"({"line":1,"kind":"rapid","end":[-1.5,0,0],"feed_mm_s":5.5})"));
    EXPECT_EQ(m[1], nlohmann::json::parse(R"({"line":2,"kind":"ttl","ttl":"on"})"));
    EXPECT_EQ(m[2], nlohmann::json::parse(R"({"line":2,"kind":"arc","end":[8.5,0,0],"center":[3.5,0,0],)"
                                          R"("plane":"XY","direction":"cw","feed_mm_s":2})"));
    EXPECT_EQ(m[3], nlohmann::json::parse(R"({"line":3,"kind":"dwell","dwell_ms":250})"));
    EXPECT_EQ(m[4], nlohmann::json::parse(R"({"line":4,"kind":"analog","analog_v":10})"));
    EXPECT_EQ(m[5], nlohmann::json::parse(R"({"line":5,"kind":"ttl","ttl":"off"})"));
    // the clockwise half circle from (-1.5, 0) around (3.5, 0) passes over the top, (3.5, 5)
    EXPECT_EQ(j["bounds"]["min"], nlohmann::json::parse("[-1.5,0,0]"));
    EXPECT_EQ(j["bounds"]["max"], nlohmann::json::parse("[8.5,5,0]"));
    EXPECT_GT(j["segments"].get<int>(), 1);
}

TEST(plan_json, error_document_only) {
    bool ok = true;
    EXPECT_EQ(plan_text("G0 X1.\nG1 X2. F60\nG28 X0\n", {}, &ok),
              R"({"error":{"line":3,"column":1,"message":"unsupported code G28"}})");
    EXPECT_FALSE(ok);
}

TEST(plan_json, warnings_are_escaped_strings) {
    const auto j = nlohmann::json::parse(plan_text("G0 X1000\n/G0 X1.\n"));
    ASSERT_EQ(j["warnings"].size(), 2u);
    EXPECT_NE(j["warnings"][0].get<std::string>().find("line 1: X1000 has no decimal point"),
              std::string::npos);
}

TEST(plan_json, strings_and_numbers) {
    EXPECT_EQ(json_string("a\"b\\c\n\x01\xc3"), R"("a\"b\\c\u000a\u0001\u00c3")");
    EXPECT_EQ(json_number(0), "0");
    EXPECT_EQ(json_number(-0.0000001), "0");
    EXPECT_EQ(json_number(12.5), "12.5");
    EXPECT_EQ(json_number(-4.898979485566356), "-4.898979");
    EXPECT_EQ(json_number(1e6), "1000000");
}

// A stream that cannot seek: planned in one pass; an early error is still a clean error document.
class one_way : public std::streambuf {
  public:
    explicit one_way(std::string text) : text_(std::move(text)) {
        setg(text_.data(), text_.data(), text_.data() + text_.size());
    }

  protected:
    pos_type seekoff(off_type, std::ios_base::seekdir, std::ios_base::openmode) override {
        return pos_type(-1);
    }
    pos_type seekpos(pos_type, std::ios_base::openmode) override { return pos_type(-1); }

  private:
    std::string text_;
};

TEST(plan_json, non_seekable_stream) {
    one_way buf("G0 X2.\n");
    std::istream in(&buf);
    std::ostringstream out;
    EXPECT_TRUE(write_plan_json(in, gcode_options{}, out));
    const auto j = nlohmann::json::parse(out.str());
    EXPECT_EQ(j["moves"].size(), 1u);
}

}  // namespace
}  // namespace gw::gcode
