#include "gateway/gcode/gcode_arc.hpp"

#include <cmath>
#include <numbers>
#include <string>
#include <variant>

#include <gtest/gtest.h>

namespace gw::gcode {
namespace {

constexpr double pi = std::numbers::pi;

arc_geometry full_circle(double r) {
    auto g = arc_from_center({0, 0, 0}, {0, 0, 0}, r, 0, arc_plane::xy, arc_direction::ccw, {});
    return std::get<arc_geometry>(g);
}

// #45 the count is the smallest whose chord error stays within the tolerance, derived from the
// sagitta of a regular polygon: r (1 - cos(pi / n)).
struct segment_case {
    double radius;
    double tolerance;
};

class segment_count_test : public ::testing::TestWithParam<segment_case> {};

TEST_P(segment_count_test, smallest_count_within_tolerance_45) {
    const double r = GetParam().radius;
    const double tol = GetParam().tolerance;
    const auto g = full_circle(r);
    const auto n = arc_segment_count(g, tol);
    ASSERT_GE(n, 4u);  // at most 90 degrees per segment
    auto sagitta = [r](double segments) { return r * (1 - std::cos(pi / segments)); };
    EXPECT_LE(sagitta(static_cast<double>(n)), tol * (1 + 1e-9));
    if (n > 4) {
        EXPECT_GT(sagitta(static_cast<double>(n - 1)), tol);
    }
    // The real polyline: each chord's midpoint is within the tolerance of the circle.
    for (std::uint64_t i = 0; i < n; ++i) {
        const vec3 a = arc_point(g, static_cast<double>(i) / static_cast<double>(n));
        const vec3 b = arc_point(g, static_cast<double>(i + 1) / static_cast<double>(n));
        const double mid_radius = std::hypot((a.x + b.x) / 2 - r, (a.y + b.y) / 2);
        EXPECT_LE(r - mid_radius, tol * (1 + 1e-6));
    }
}

INSTANTIATE_TEST_SUITE_P(arc, segment_count_test,
                         ::testing::Values(segment_case{0.05, 0.001},  // 50 um circle (grbl: 11, Klipper: 1)
                                           segment_case{5, 0.001}, segment_case{100, 0.001},
                                           segment_case{1000, 0.0001}, segment_case{0.0005, 0.001},
                                           segment_case{10, 5}));

TEST(arc, fifty_micrometre_circle_needs_about_fifteen_segments_45) {
    // 2 r sin^2(step / 4) = tol -> step = 4 asin(sqrt(0.001 / 0.1)) = 0.40067 rad -> 2 pi / 0.40067 = 15.68
    EXPECT_EQ(arc_segment_count(full_circle(0.05), 0.001), 16u);
}

TEST(arc, segment_count_cap) {
    const auto g = full_circle(1e9);
    EXPECT_EQ(arc_segment_count(g, 1e-7), 0u);  // more than max_arc_segments
}

TEST(arc, last_point_is_the_programmed_end_42) {
    auto g = std::get<arc_geometry>(
        arc_from_center({0, 0, 0}, {10, 0, 1}, 5.0004, 0, arc_plane::xy, arc_direction::cw, {}));
    EXPECT_EQ(arc_point(g, 1.0), (vec3{10, 0, 1}));
    EXPECT_EQ(arc_point(g, 0.0), (vec3{0, 0, 0}));
}

TEST(arc, r_form_centres_38) {
    const double h = std::sqrt(24.0);
    struct row {
        arc_direction dir;
        double r;
        double center_b;
    };
    for (const auto& [dir, r, cb] : {row{arc_direction::cw, 7, -h}, row{arc_direction::cw, -7, h},
                                     row{arc_direction::ccw, 7, h}, row{arc_direction::ccw, -7, -h}}) {
        const auto g =
            std::get<arc_geometry>(arc_from_radius({0, 0, 0}, {10, 0, 0}, r, arc_plane::xy, dir, {}));
        EXPECT_NEAR(g.center.x, 5, 1e-12);
        EXPECT_NEAR(g.center.y, cb, 1e-12);
        EXPECT_NEAR(g.start_radius, 7, 1e-12);
        EXPECT_NEAR(g.end_radius, 7, 1e-12);
        // short arc (|R| > 0) under 180 degrees, long arc over
        EXPECT_EQ(std::abs(g.sweep) < pi, r > 0);
    }
}

TEST(arc, r_form_in_zx_plane_uses_z_x_order_32) {
    // G18 from (0,0,0) to X10: chord along +X is the plane's second axis. G02 R5: half circle through
    // Z = -5 (clockwise seen from +Y), as the I/J/K form of the same arc.
    const auto g = std::get<arc_geometry>(
        arc_from_radius({0, 0, 0}, {10, 0, 0}, 5, arc_plane::zx, arc_direction::cw, {}));
    const vec3 mid = arc_point(g, 0.5);
    EXPECT_NEAR(mid.x, 5, 1e-9);
    EXPECT_NEAR(mid.z, -5, 1e-9);
}

TEST(arc, errors) {
    auto err = [](const std::variant<arc_geometry, std::string>& v) {
        return std::get_if<std::string>(&v) != nullptr;
    };
    EXPECT_TRUE(err(arc_from_radius({0, 0, 0}, {0, 0, 0}, 5, arc_plane::xy, arc_direction::cw, {})));
    EXPECT_TRUE(err(arc_from_radius({0, 0, 0}, {10, 0, 0}, 4.9998, arc_plane::xy, arc_direction::cw, {})));
    EXPECT_FALSE(err(arc_from_radius({0, 0, 0}, {10, 0, 0}, 4.99991, arc_plane::xy, arc_direction::cw, {})));
    EXPECT_TRUE(err(arc_from_center({0, 0, 0}, {1, 0, 0}, 0, 0, arc_plane::xy, arc_direction::cw, {})));
    EXPECT_TRUE(err(
        arc_from_center({0, 0, 0}, {1, 0, 0}, 1, 0, arc_plane::xy, arc_direction::cw, {})));  // end = centre
}

TEST(arc, plane_length) {
    const auto g = full_circle(2);
    EXPECT_NEAR(arc_plane_length(g), 4 * pi, 1e-12);
}

}  // namespace
}  // namespace gw::gcode
