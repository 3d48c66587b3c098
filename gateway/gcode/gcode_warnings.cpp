#include "gateway/gcode/gcode_warnings.hpp"

namespace gw::gcode {

void gcode_warnings::add(warning_kind kind, int line, std::string message) {
    auto& e = entries_[static_cast<std::size_t>(kind)];
    if (e.count++ == 0) {
        e.line = line;
        e.message = std::move(message);
    }
}

bool gcode_warnings::empty() const {
    for (const auto& e : entries_)
        if (e.count > 0) return false;
    return true;
}

std::vector<std::string> gcode_warnings::texts() const {
    std::vector<std::string> out;
    for (const auto& e : entries_) {
        if (e.count == 0) continue;
        std::string t = e.line > 0 ? "line " + std::to_string(e.line) + ": " + e.message : e.message;
        if (e.count > 1) t += " (" + std::to_string(e.count - 1) + " more like it)";
        out.push_back(std::move(t));
    }
    return out;
}

}  // namespace gw::gcode
