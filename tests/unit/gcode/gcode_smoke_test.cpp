#include <sstream>

#include <gtest/gtest.h>

#include "gateway/gcode/gcode_planner.hpp"

namespace gw::gcode {
namespace {

TEST(gcode_smoke, plans_a_line) {
    std::istringstream in("G01 X1. F60\n");
    auto r = check_program(in, gcode_options{});
    ASSERT_TRUE(std::holds_alternative<plan_summary>(r));
    EXPECT_EQ(std::get<plan_summary>(r).segments, 1u);
}

}  // namespace
}  // namespace gw::gcode
