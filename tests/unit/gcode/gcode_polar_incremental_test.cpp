// G16 polar coordinates under G91 (../shared/docs/gcode-semantics.md #47-#50; the decision in
// gateway/gcode/README.md): the pole follows the radius word (incremental -> the current position,
// omitted -> the work zero with the current distance as radius), and an incremental angle adds to the
// current position's angle about the work zero.
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/unit/gcode/plan_helper.hpp"

namespace gw::gcode {
namespace {

using test::plan;

struct xyz {
    double x = 0;
    double y = 0;
    double z = 0;
};

// r at a degrees in the XY plane.
xyz at(double r, double degrees) {
    const double a = degrees * std::numbers::pi / 180;
    return {r * std::cos(a), r * std::sin(a), 0};
}

struct polar_case {
    std::string name;
    std::string program;
    std::vector<xyz> ends;  // every planned move's end, in order
    double xyz_scale = 1;
};

class polar_incremental : public ::testing::TestWithParam<polar_case> {};

TEST_P(polar_incremental, ends_where_fanuc_puts_them) {
    const auto& c = GetParam();
    gcode_options o;
    o.xyz_scale = c.xyz_scale;
    const auto p = plan(c.program, o);
    ASSERT_TRUE(p.ok()) << p.error->message;
    ASSERT_EQ(p.moves.size(), c.ends.size()) << c.program;
    for (std::size_t i = 0; i < c.ends.size(); ++i) {
        EXPECT_NEAR(p.moves[i].end.x, c.ends[i].x, 1e-9) << "move " << i;
        EXPECT_NEAR(p.moves[i].end.y, c.ends[i].y, 1e-9) << "move " << i;
        EXPECT_NEAR(p.moves[i].end.z, c.ends[i].z, 1e-9) << "move " << i;
    }
}

INSTANTIATE_TEST_SUITE_P(
    all, polar_incremental,
    ::testing::Values(
        // FANUC's bolt-hole example: radius absolute, then the angle incremental with the radius
        // omitted -> the pole stays at the work zero and the radius stays 100.
        polar_case{"bolt_hole_angle_increments",
                   "G17 G90 G16 G00 X100. Y30.\nG91 Y120.\nY120.\n",
                   {at(100, 30), at(100, 150), at(100, 270)}},
        polar_case{
            "negative_angle_increment", "G90 G16 G00 X100. Y30.\nG91 Y-120.\n", {at(100, 30), at(100, -90)}},
        // The base of the increment is the current position's angle, also when it was reached by a
        // Cartesian move before G16 (not 0).
        polar_case{
            "angle_only_from_cartesian_position", "G0 X0 Y10.\nG91 G16 G0 Y30.\n", {{0, 10, 0}, at(10, 120)}},
        // An incremental radius: the pole is the current position; no angle word -> the current
        // position's angle (the move runs radially outwards).
        polar_case{"radius_only_moves_radially", "G0 X3. Y4.\nG91 G16 G0 X5.\n", {{3, 4, 0}, {6, 8, 0}}},
        // From the work zero (the vector of #48): pole (0,0), 20 mm at 20 degrees.
        polar_case{"radius_and_angle_from_work_zero", "G91 G16 G01 X20. Y20. F60\n", {at(20, 20)}},
        polar_case{"radius_and_angle_from_elsewhere",
                   "G0 X10.\nG91 G16 G01 X5. Y90. F60\n",
                   {{10, 0, 0}, {10, 5, 0}}},
        polar_case{"increment_adds_to_current_angle",
                   "G0 X0 Y10.\nG91 G16 G0 X5. Y90.\n",
                   {{0, 10, 0}, {-5, 10, 0}}},
        // Chained incremental radius moves: each angle is relative to the current position's angle.
        polar_case{"chained_incremental_radius",
                   "G91 G16 G0 X20. Y20.\nX20. Y20.\n",
                   {at(20, 20), {at(20, 20).x + at(20, 40).x, at(20, 20).y + at(20, 40).y, 0}}},
        // The helical/third axis stays Cartesian and incremental.
        polar_case{"third_axis_is_cartesian",
                   "G0 X3. Y4. Z1.\nG91 G16 G0 Z1.\nY90.\n",
                   {{3, 4, 1}, {3, 4, 2}, {-4, 3, 2}}},
        // G18: Z is the radius, X the angle (Z-X plane); G19: Y radius, Z angle.
        polar_case{"g18_angle_increment", "G18 G0 Z10.\nG91 G16 G0 X90.\n", {{0, 0, 10}, {10, 0, 0}}},
        polar_case{"g19_angle_increment", "G19 G0 Y10.\nG91 G16 G0 Z90.\n", {{0, 10, 0}, {0, 0, 10}}},
        // The incremental radius is a length (units, scale); the angle is not.
        polar_case{"inch_radius", "G20 G0 X1.\nG91 G16 G0 X1. Y90.\n", {{25.4, 0, 0}, {25.4, 25.4, 0}}},
        polar_case{"scaled_radius", "G0 X10.\nG91 G16 G0 X5. Y90.\n", {{20, 0, 0}, {20, 10, 0}}, 2},
        // Back to G90: the pole is the work zero again.
        polar_case{"g90_after_g91", "G91 G16 G0 X10. Y90.\nG90 X10. Y0.\n", {{0, 10, 0}, {10, 0, 0}}},
        // G15 ends polar mode: G91 words are Cartesian increments again.
        polar_case{"g15_cartesian_again",
                   "G0 X3. Y4.\nG91 G16 G0 X5.\nG15 X1. Y1.\n",
                   {{3, 4, 0}, {6, 8, 0}, {7, 9, 0}}},
        // At the work zero an angle alone goes nowhere (radius 0: the move is dropped); a radius then
        // starts at angle 0.
        polar_case{"angle_alone_at_work_zero", "G91 G16 G0 Y45.\nX10.\n", {{10, 0, 0}}}),
    [](const auto& info) { return info.param.name; });

// An arc with the radius omitted under G91: the end stays on the circle about the work zero; I/J stay
// Cartesian (relative to the start).
TEST(polar_incremental_arc, angle_increment_on_the_circle_about_the_work_zero) {
    const auto p = plan("G90 G16 G0 X10. Y0.\nG91 G03 Y90. I-10. J0 F60\n");
    ASSERT_TRUE(p.ok()) << p.error->message;
    ASSERT_EQ(p.moves.size(), 2u);
    EXPECT_EQ(p.moves[1].kind, move_kind::arc);
    EXPECT_NEAR(p.moves[1].end.x, 0, 1e-9);
    EXPECT_NEAR(p.moves[1].end.y, 10, 1e-9);
    EXPECT_NEAR(p.moves[1].arc.center.x, 0, 1e-12);
    EXPECT_NEAR(p.moves[1].arc.center.y, 0, 1e-12);
}

// Least-increment reading applies to the radius (0.001 mm) and the angle (0.001 degree).
TEST(polar_incremental_decimals, least_increment_radius_and_angle) {
    gcode_options o;
    o.decimal_point = decimal_point_reading::least_increment;
    const auto p = plan("G0 X1000\nG91 G16 G0 X1000 Y90000\n", o);
    ASSERT_TRUE(p.ok()) << p.error->message;
    ASSERT_EQ(p.moves.size(), 2u);
    EXPECT_NEAR(p.moves[1].end.x, 1, 1e-9);
    EXPECT_NEAR(p.moves[1].end.y, 1, 1e-9);
}

}  // namespace
}  // namespace gw::gcode
