#pragma once
// Test helper: plans a program given as text and keeps every move.

#include <sstream>
#include <string>
#include <variant>
#include <vector>

#include "gateway/gcode/gcode_planner.hpp"

namespace gw::gcode::test {

struct planned {
    std::vector<planned_move> moves;
    plan_summary summary;
    std::optional<gcode_error> error;

    bool ok() const { return !error.has_value(); }
    bool warned(const std::string& needle) const {
        for (const auto& w : summary.warnings)
            if (w.find(needle) != std::string::npos) return true;
        return false;
    }
};

class collecting_sink final : public move_sink {
  public:
    explicit collecting_sink(std::vector<planned_move>& moves) : moves_(moves) {}
    void on_move(const planned_move& m) override { moves_.push_back(m); }

  private:
    std::vector<planned_move>& moves_;
};

inline planned plan(const std::string& program, const gcode_options& options = {}) {
    planned p;
    std::istringstream in(program);
    collecting_sink sink(p.moves);
    auto r = plan_program(in, options, sink);
    if (auto* e = std::get_if<gcode_error>(&r)) {
        p.error = *e;
        p.moves.clear();
    } else {
        p.summary = std::get<plan_summary>(r);
    }
    return p;
}

}  // namespace gw::gcode::test
