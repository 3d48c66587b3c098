#include "devices/sim/letter_parameters.hpp"

#include <algorithm>

#include "devices/ms2000/error.hpp"

namespace gw::devices::sim {

std::function<int(double)> assigns(double& field) {
    return [&field](double value) {
        field = value;
        return 0;
    };
}

int ignores(double /*value*/) {
    return 0;
}

letter_parameters_outcome apply_letter_parameters(const command_line& cmd,
                                                  std::span<const letter_parameter> letters) {
    letter_parameters_outcome outcome;
    for (const auto& arg : cmd.args) {
        const auto it = std::find_if(letters.begin(), letters.end(),
                                     [&](const letter_parameter& p) { return p.letter == arg.letter; });
        const bool query = arg.kind == line_argument::op::query;
        if (it == letters.end() || !(query ? bool(it->query) : bool(it->set))) {
            outcome.error = ms2000::unrecognized_axis;
            return outcome;
        }
        if (query) {
            outcome.answers.emplace_back(arg.letter, it->query());
            continue;
        }
        if (const int refused = it->set(arg.value); refused != 0) {
            outcome.error = refused;
            return outcome;
        }
    }
    return outcome;
}

}  // namespace gw::devices::sim
