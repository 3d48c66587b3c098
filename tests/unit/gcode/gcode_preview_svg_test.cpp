// The preview SVG: well-formed XML (parsed back with Boost.PropertyTree), the three line styles, +Y
// drawn upwards, the other views, bounded output for big programs, errors writing nothing; and the
// plan summary JSON.
#include "gateway/gcode/gcode_preview_svg.hpp"

#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <boost/property_tree/ptree.hpp>
#include <boost/property_tree/xml_parser.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gateway/gcode/gcode_plan_summary_json.hpp"

namespace gw::gcode {
namespace {

namespace pt = boost::property_tree;

struct drawn {
    std::string svg;
    std::optional<gcode_error> error;
};

drawn draw(const std::string& program, preview_options view = {}, gcode_options options = {}) {
    std::istringstream in(program);
    std::ostringstream out;
    drawn d;
    d.error = write_preview_svg(in, options, view, out);
    d.svg = out.str();
    return d;
}

pt::ptree parse_xml(const std::string& svg) {
    std::istringstream in(svg);
    pt::ptree tree;
    pt::read_xml(in, tree);  // throws on malformed XML
    return tree;
}

// Every path of a class, as its list of (x, y) points.
std::vector<std::vector<std::pair<double, double>>> paths_of(const pt::ptree& tree, const std::string& cls) {
    std::vector<std::vector<std::pair<double, double>>> out;
    for (const auto& [name, node] : tree.get_child("svg")) {
        if (name != "path" || node.get<std::string>("<xmlattr>.class") != cls) continue;
        const std::string d = node.get<std::string>("<xmlattr>.d");
        static const std::regex point(R"([ML](-?[0-9.]+) (-?[0-9.]+))");
        std::vector<std::pair<double, double>> pts;
        for (auto it = std::sregex_iterator(d.begin(), d.end(), point); it != std::sregex_iterator(); ++it)
            pts.emplace_back(std::stod((*it)[1]), std::stod((*it)[2]));
        out.push_back(std::move(pts));
    }
    return out;
}

const std::string square = "G21 G90\nG00 X1 Y1\nG01 X9 F120\nM03\nG01 Y9\nM05\nG01 X1\nG00 X0 Y0\n";

TEST(gcode_preview_svg, is_well_formed_with_the_three_styles) {
    auto d = draw(square);
    ASSERT_FALSE(d.error) << d.error->message;
    auto tree = parse_xml(d.svg);
    EXPECT_EQ(tree.get<std::string>("svg.<xmlattr>.xmlns"), "http://www.w3.org/2000/svg");
    EXPECT_EQ(paths_of(tree, "rapid").size(), 2u);
    EXPECT_EQ(paths_of(tree, "feed").size(), 2u);
    ASSERT_EQ(paths_of(tree, "ttl").size(), 1u);
    EXPECT_NE(d.svg.find("stroke-dasharray"), std::string::npos);              // rapid moves are dashed
    EXPECT_NE(d.svg.find("moves 7, segments 5"), std::string::npos) << d.svg;  // the <desc> totals
}

TEST(gcode_preview_svg, plus_y_is_up_and_x_is_right) {
    auto d = draw(square, {.width_px = 800});
    ASSERT_FALSE(d.error);
    auto tree = parse_xml(d.svg);
    auto ttl = paths_of(tree, "ttl").at(0);  // G01 Y9 from (9, 1): straight up on the page
    ASSERT_EQ(ttl.size(), 2u);
    EXPECT_DOUBLE_EQ(ttl[0].first, ttl[1].first);
    EXPECT_GT(ttl[0].second, ttl[1].second);   // SVG y grows downwards: +Y must shrink it
    auto feed = paths_of(tree, "feed").at(0);  // G01 X9 from (1, 1): to the right
    EXPECT_LT(feed.front().first, feed.back().first);
    EXPECT_DOUBLE_EQ(feed.front().second, feed.back().second);
    // Bounds 0..9 on both axes: a square picture 800 px wide.
    EXPECT_EQ(tree.get<std::string>("svg.<xmlattr>.width"), "800");
    EXPECT_EQ(tree.get<std::string>("svg.<xmlattr>.height"), "800");
    // Y9 is at the top margin, Y1 near the bottom.
    EXPECT_LT(ttl[1].second, 20);
    EXPECT_GT(ttl[0].second, 700);
}

TEST(gcode_preview_svg, other_views_project_on_their_plane) {
    const std::string program = "G21 G90 G01 Z5 F60\nG01 X2\n";
    auto zx = draw(program, {.view = arc_plane::zx});
    ASSERT_FALSE(zx.error);
    auto feed = paths_of(parse_xml(zx.svg), "feed");
    ASSERT_EQ(feed.size(), 1u);
    ASSERT_EQ(feed[0].size(), 3u);
    EXPECT_LT(feed[0][0].first, feed[0][1].first);    // +Z is to the right in ZX
    EXPECT_GT(feed[0][1].second, feed[0][2].second);  // +X is up in ZX
    EXPECT_NE(zx.svg.find("Z right, X up"), std::string::npos);
}

TEST(gcode_preview_svg, arcs_are_drawn_with_pixel_tolerance_not_machine_segments) {
    auto d = draw("G21 G90 G01 X10 F600\nG03 X10 Y0 I-10 J0\n", {.width_px = 200});
    ASSERT_FALSE(d.error);
    auto feed = paths_of(parse_xml(d.svg), "feed");
    ASSERT_EQ(feed.size(), 1u);
    // The machine needs thousands of 1 um chords for r = 10 mm; a 200 px drawing far fewer.
    EXPECT_GT(feed[0].size(), 20u);
    EXPECT_LT(feed[0].size(), 300u);
}

TEST(gcode_preview_svg, big_programs_are_decimated_to_a_bounded_size) {
    std::string program = "G21 G90 G01 F600\n";
    for (int i = 0; i < 200000; ++i)
        program += "X" + std::to_string(i % 2 == 0 ? 100 : 0) + " Y" + std::to_string(i * 0.001) + "\n";
    auto d = draw(program, {.max_points = 1000});
    ASSERT_FALSE(d.error);
    auto tree = parse_xml(d.svg);
    std::size_t points = 0;
    for (const auto& p : paths_of(tree, "feed"))
        points += p.size();
    EXPECT_LE(points, 2000u + 200);  // the cap plus the M of each split path
    EXPECT_GT(points, 500u);
    EXPECT_LT(d.svg.size(), 64u * 1024) << d.svg.size();
    EXPECT_NE(d.svg.find("every 200th"), std::string::npos) << d.svg.substr(d.svg.size() - 200);
}

TEST(gcode_preview_svg, an_error_writes_nothing) {
    auto d = draw("G21\nG01 X1\n");  // G01 before F
    ASSERT_TRUE(d.error);
    EXPECT_EQ(d.error->line, 2);
    EXPECT_TRUE(d.svg.empty());
}

TEST(gcode_preview_svg, options_are_parsed_and_checked) {
    preview_options o;
    EXPECT_TRUE(set_preview_option(o, "view", "YZ").known);
    EXPECT_EQ(o.view, arc_plane::yz);
    EXPECT_TRUE(set_preview_option(o, "view", "XZ").error);
    EXPECT_FALSE(set_preview_option(o, "width_px", "400").error);
    EXPECT_EQ(o.width_px, 400);
    EXPECT_TRUE(set_preview_option(o, "width_px", "10").error);
    EXPECT_TRUE(set_preview_option(o, "max_points", "150.5").error);
    EXPECT_FALSE(set_preview_option(o, "max_points", "1.5e3").error);  // a whole number
    EXPECT_EQ(o.max_points, 1500u);
    EXPECT_FALSE(set_preview_option(o, "xyz_scale", "2").known);
}

TEST(gcode_plan_summary_json, has_the_plan_numbers_without_moves) {
    std::istringstream in(square);
    std::ostringstream out;
    ASSERT_TRUE(write_plan_summary_json(in, gcode_options{}, out));
    auto j = nlohmann::json::parse(out.str());
    EXPECT_FALSE(j.contains("moves"));
    EXPECT_EQ(j["units"], "mm");
    EXPECT_EQ(j["lines"], 8);
    EXPECT_EQ(j["segments"], 5);
    EXPECT_EQ(j["bounds"]["max"], nlohmann::json::parse("[9,9,0]"));
    EXPECT_GT(j["estimated_s"].get<double>(), 0);

    std::istringstream bad("G01 X1\n");
    std::ostringstream err;
    EXPECT_FALSE(write_plan_summary_json(bad, gcode_options{}, err));
    auto e = nlohmann::json::parse(err.str());
    EXPECT_EQ(e["error"]["line"], 1);
}

}  // namespace
}  // namespace gw::gcode
