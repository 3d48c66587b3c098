#pragma once
// The letters of one firmware command that a client may query ("SCANR X?") or set ("SCANR X=1"),
// read in one place: SCANR, SCANV and ZS differ only in their table of letters. Pure.
//
//   const letter_parameter letters[] = {
//       {'X', [&] { return num(start); }, assigns(start)},
//       {'T', nullptr, ignores},  // accepted, not simulated; "T?" is refused
//   };
//   auto outcome = apply_letter_parameters(cmd, letters);

#include <functional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "devices/sim/command_line.hpp"

namespace gw::devices::sim {

struct letter_parameter {
    char letter = 'X';
    // The value "L?" answers; empty when the firmware refuses to query the letter.
    std::function<std::string()> query;
    // Applies "L=v" (or a bare "L", v = 0): 0, or the ms2000 error code that refuses the value; empty
    // when the firmware refuses to set the letter.
    std::function<int(double)> set;
};

struct letter_parameters_outcome {
    // The first refusal, in argument order (unrecognized_axis for a letter the command does not
    // have); 0 when every argument was taken. The settings before it stay applied.
    int error = 0;
    // The answers to the queries, in argument order; a reply ":A X=.. Y=.." when not empty.
    std::vector<std::pair<char, std::string>> answers;
};

// A setter that stores any number in `field`, which must outlive the apply_letter_parameters call.
std::function<int(double)> assigns(double& field);
// A setter that takes any number and keeps nothing: a setting the simulator does not model.
int ignores(double value);

// Queries and settings are read in the order given and may be mixed; the command decides what a
// query among settings means (the firmware's commands answer the queries and drop the settings, or
// keep both).
letter_parameters_outcome apply_letter_parameters(const command_line& cmd,
                                                  std::span<const letter_parameter> letters);

}  // namespace gw::devices::sim
