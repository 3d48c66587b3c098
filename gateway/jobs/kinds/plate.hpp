#pragma once
// Well plates and rectangular grids: geometry of the SBS presets, well names ("A1", "H12", "AA3"),
// visit orders and well positions relative to A1. Pure.
//
// Conventions (seed ARRAY MODULE): columns run along X, rows along Y; the signed steps are those of
// "ARRAY X=cols Y=rows Z=column_step F=row_step", so a standard plate has (+pitch, -pitch): row B
// lies in the negative Y direction of row A. Rotation turns the grid about A1, counter-clockwise
// for positive angles in stage coordinates.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace gw::jobs {

struct plate_geometry {
    int columns = 12;
    int rows = 8;
    double column_step_mm = 9.0;  // signed X distance from column 1 to column 2
    double row_step_mm = -9.0;    // signed Y distance from row A to row B

    bool operator==(const plate_geometry&) const = default;
};

// Rows beyond this have no two-letter name ("ZZ" is row 702).
inline constexpr int max_plate_rows = 702;
inline constexpr int max_plate_columns = 1000;

// "6", "12", "24", "48", "96", "384" (SBS footprint: 3x2 39.12 mm ... 24x16 4.5 mm).
std::optional<plate_geometry> plate_preset(std::string_view name);
std::vector<std::string_view> plate_preset_names();

// A well by 0-based row and column.
struct well_index {
    int row = 0;
    int column = 0;
    bool operator==(const well_index&) const = default;
};

// "A", "B", ... "Z", "AA", "AB", ... (0-based row; bijective base 26).
std::string row_name(int row);
// "A1", "H12", "AF48".
std::string well_name(well_index w);
// Parses "A1".."P24" (letters case-insensitive, no leading zeros, no spaces); empty when malformed
// or outside the grid.
std::optional<well_index> parse_well(std::string_view name, const plate_geometry& g);

enum class well_order : std::uint8_t {
    raster,      // every row left to right (column 1 first)
    serpentine,  // row A left to right, row B right to left, ... (what the ARRAY module does)
};

// Every well of the grid in visit order.
std::vector<well_index> visit_order(const plate_geometry& g, well_order order);
// Position of the well in visit order (0-based), for the full grid.
std::size_t visit_index(const plate_geometry& g, well_order order, well_index w);

// Offset of the well from A1 in micrometres (X, Y), rotated by rotation_deg about A1.
std::pair<double, double> well_offset_um(const plate_geometry& g, well_index w, double rotation_deg = 0);

}  // namespace gw::jobs
