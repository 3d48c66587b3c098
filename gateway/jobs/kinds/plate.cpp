#include "gateway/jobs/kinds/plate.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <numbers>

namespace gw::jobs {

namespace {

struct preset_row {
    std::string_view name;
    int columns;
    int rows;
    double pitch_mm;
};

// SBS/ANSI footprint well-to-well spacing per format.
constexpr std::array<preset_row, 6> presets{{
    {"6", 3, 2, 39.12},
    {"12", 4, 3, 26.01},
    {"24", 6, 4, 19.30},
    {"48", 8, 6, 13.08},
    {"96", 12, 8, 9.00},
    {"384", 24, 16, 4.50},
}};

bool is_letter(char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z');
}

int letter_value(char c) {
    return (c >= 'a' ? c - 'a' : c - 'A') + 1;
}

}  // namespace

std::optional<plate_geometry> plate_preset(std::string_view name) {
    for (const auto& p : presets)
        if (p.name == name) return plate_geometry{p.columns, p.rows, p.pitch_mm, -p.pitch_mm};
    return std::nullopt;
}

std::vector<std::string_view> plate_preset_names() {
    std::vector<std::string_view> names;
    for (const auto& p : presets)
        names.push_back(p.name);
    return names;
}

std::string row_name(int row) {
    std::string name;
    for (int n = row + 1; n > 0; n = (n - 1) / 26)
        name.insert(name.begin(), static_cast<char>('A' + (n - 1) % 26));
    return name;
}

std::string well_name(well_index w) {
    return row_name(w.row) + std::to_string(w.column + 1);
}

std::optional<well_index> parse_well(std::string_view name, const plate_geometry& g) {
    std::size_t letters = 0;
    while (letters < name.size() && is_letter(name[letters]))
        ++letters;
    if (letters == 0 || letters > 2 || letters == name.size()) return std::nullopt;
    int row = 0;
    for (std::size_t i = 0; i < letters; ++i)
        row = row * 26 + letter_value(name[i]);
    const auto digits = name.substr(letters);
    if (digits.front() == '0') return std::nullopt;
    int column = 0;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), column);
    if (ec != std::errc{} || end != digits.data() + digits.size()) return std::nullopt;
    if (row < 1 || row > g.rows || column < 1 || column > g.columns) return std::nullopt;
    return well_index{row - 1, column - 1};
}

std::vector<well_index> visit_order(const plate_geometry& g, well_order order) {
    std::vector<well_index> wells;
    if (g.rows <= 0 || g.columns <= 0) return wells;
    wells.reserve(static_cast<std::size_t>(g.rows) * static_cast<std::size_t>(g.columns));
    for (int r = 0; r < g.rows; ++r) {
        const bool reverse = order == well_order::serpentine && r % 2 == 1;
        for (int k = 0; k < g.columns; ++k)
            wells.push_back({r, reverse ? g.columns - 1 - k : k});
    }
    return wells;
}

std::size_t visit_index(const plate_geometry& g, well_order order, well_index w) {
    const bool reverse = order == well_order::serpentine && w.row % 2 == 1;
    const int k = reverse ? g.columns - 1 - w.column : w.column;
    return static_cast<std::size_t>(w.row) * static_cast<std::size_t>(g.columns) +
           static_cast<std::size_t>(k);
}

std::pair<double, double> well_offset_um(const plate_geometry& g, well_index w, double rotation_deg) {
    const double x = w.column * g.column_step_mm * 1000.0;
    const double y = w.row * g.row_step_mm * 1000.0;
    if (rotation_deg == 0) return {x, y};
    const double a = rotation_deg * std::numbers::pi / 180.0;
    const double c = std::cos(a), s = std::sin(a);
    return {x * c - y * s, x * s + y * c};
}

}  // namespace gw::jobs
