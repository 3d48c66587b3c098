// Plate geometry, well names, visit orders and rotation (gateway/jobs/kinds/plate.hpp).
#include <cctype>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gateway/jobs/kinds/plate.hpp"

namespace gw::jobs {
namespace {

TEST(ArrayPlate, RowNames) {
    const std::vector<std::pair<int, std::string>> cases{{0, "A"},   {7, "H"},   {15, "P"},
                                                         {25, "Z"},  {26, "AA"}, {31, "AF"},
                                                         {51, "AZ"}, {52, "BA"}, {701, "ZZ"}};
    for (const auto& [row, name] : cases)
        EXPECT_EQ(row_name(row), name) << row;
}

TEST(ArrayPlate, WellNames) {
    EXPECT_EQ(well_name({0, 0}), "A1");
    EXPECT_EQ(well_name({7, 11}), "H12");
    EXPECT_EQ(well_name({15, 23}), "P24");
    EXPECT_EQ(well_name({31, 47}), "AF48");
}

TEST(ArrayPlate, EveryPresetsGeometry) {
    struct row {
        const char* name;
        int columns, rows;
        double pitch;
    };
    const std::vector<row> cases{{"6", 3, 2, 39.12},  {"12", 4, 3, 26.01}, {"24", 6, 4, 19.30},
                                 {"48", 8, 6, 13.08}, {"96", 12, 8, 9.00}, {"384", 24, 16, 4.50}};
    for (const auto& c : cases) {
        const auto g = plate_preset(c.name);
        ASSERT_TRUE(g) << c.name;
        EXPECT_EQ(g->columns, c.columns) << c.name;
        EXPECT_EQ(g->rows, c.rows) << c.name;
        EXPECT_DOUBLE_EQ(g->column_step_mm, c.pitch) << c.name;
        EXPECT_DOUBLE_EQ(g->row_step_mm, -c.pitch) << c.name;
        EXPECT_EQ(g->columns * g->rows, std::stoi(c.name)) << c.name;
    }
    EXPECT_EQ(plate_preset_names().size(), cases.size());
    EXPECT_FALSE(plate_preset("1536"));
    EXPECT_FALSE(plate_preset(""));
    EXPECT_FALSE(plate_preset("96 "));
}

TEST(ArrayPlate, ParseWell) {
    const auto p96 = *plate_preset("96");
    const auto p384 = *plate_preset("384");
    const plate_geometry big{48, 32, 2.25, -2.25};
    struct row {
        const char* text;
        const plate_geometry* g;
        std::optional<well_index> want;
    };
    const std::vector<row> cases{
        {"A1", &p96, well_index{0, 0}},
        {"H12", &p96, well_index{7, 11}},
        {"h12", &p96, well_index{7, 11}},
        {"C7", &p96, well_index{2, 6}},
        {"P24", &p384, well_index{15, 23}},
        {"AF48", &big, well_index{31, 47}},
        {"A13", &p96, std::nullopt},
        {"I1", &p96, std::nullopt},
        {"Q1", &p384, std::nullopt},
        {"A0", &p96, std::nullopt},
        {"A01", &p96, std::nullopt},
        {"1A", &p96, std::nullopt},
        {"", &p96, std::nullopt},
        {"A", &p96, std::nullopt},
        {"A1x", &p96, std::nullopt},
        {"A 1", &p96, std::nullopt},
        {"AAA1", &big, std::nullopt},
        {"A-1", &p96, std::nullopt},
        {"A+1", &p96, std::nullopt},
        {"AG1", &big, std::nullopt},
        {"A99999999999", &p96, std::nullopt},
    };
    for (const auto& c : cases) {
        const auto got = parse_well(c.text, *c.g);
        EXPECT_EQ(got, c.want) << c.text;
        std::string upper = c.text;
        for (auto& ch : upper)
            ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
        if (got) {
            EXPECT_EQ(well_name(*got), upper);  // names round-trip
        }
    }
}

std::vector<std::string> names(const std::vector<well_index>& wells) {
    std::vector<std::string> out;
    for (const auto& w : wells)
        out.push_back(well_name(w));
    return out;
}

TEST(ArrayPlate, Orders) {
    const auto g = *plate_preset("6");
    EXPECT_EQ(names(visit_order(g, well_order::raster)),
              (std::vector<std::string>{"A1", "A2", "A3", "B1", "B2", "B3"}));
    EXPECT_EQ(names(visit_order(g, well_order::serpentine)),
              (std::vector<std::string>{"A1", "A2", "A3", "B3", "B2", "B1"}));
    const auto p96 = *plate_preset("96");
    for (const auto order : {well_order::raster, well_order::serpentine}) {
        const auto all = visit_order(p96, order);
        ASSERT_EQ(all.size(), 96u);
        for (std::size_t i = 0; i < all.size(); ++i)
            EXPECT_EQ(visit_index(p96, order, all[i]), i);
    }
    const auto serp = names(visit_order(p96, well_order::serpentine));
    EXPECT_EQ(serp[11], "A12");
    EXPECT_EQ(serp[12], "B12");
    EXPECT_EQ(serp[23], "B1");
    EXPECT_EQ(serp[95], "H1");
}

TEST(ArrayPlate, OffsetsAndRotationAboutA1) {
    const auto g = *plate_preset("96");
    struct row {
        well_index w;
        double deg;
        double x, y;
    };
    const std::vector<row> cases{
        {{0, 0}, 0, 0, 0},           {{0, 0}, 37, 0, 0},
        {{0, 1}, 0, 9000, 0},        {{1, 0}, 0, 0, -9000},
        {{7, 11}, 0, 99000, -63000}, {{0, 1}, 90, 0, 9000},
        {{1, 0}, 90, 9000, 0},       {{0, 1}, -90, 0, -9000},
        {{0, 1}, 180, -9000, 0},     {{1, 1}, 45, 9000 * std::sqrt(2.0), 0},
    };
    for (const auto& c : cases) {
        const auto [x, y] = well_offset_um(g, c.w, c.deg);
        EXPECT_NEAR(x, c.x, 1e-6) << well_name(c.w) << " " << c.deg;
        EXPECT_NEAR(y, c.y, 1e-6) << well_name(c.w) << " " << c.deg;
    }
    const auto p384 = *plate_preset("384");
    const auto [x, y] = well_offset_um(p384, {15, 23}, 0);
    EXPECT_NEAR(x, 23 * 4500.0, 1e-6);
    EXPECT_NEAR(y, -15 * 4500.0, 1e-6);
}

}  // namespace
}  // namespace gw::jobs
