#pragma once
// Serial command text for job planners and runs (what the plan previews and what run() sends), and
// the facts about a controller a job type asks for. Pure.

#include <initializer_list>
#include <map>
#include <span>
#include <string>
#include <string_view>

#include "devices/ms2000/build_info.hpp"
#include "devices/ms2000/command.hpp"
#include "devices/serial/controller_snapshot.hpp"

namespace gw::jobs {

// "X=<value>" with `decimals` digits at most (trailing zeros dropped by the command builder).
devices::ms2000::argument set_arg(char letter, double value, int decimals = 4);

// "X": an argument with the letter alone ("SCAN P", "W X Y").
devices::ms2000::argument bare_arg(char letter);

// The command a run sends: `verb` with `args` (ms2000::make_command). Throws std::invalid_argument when
// the builder refuses them: a run builds only what its spec, checked at submission, allows.
devices::ms2000::command typed_command(std::string_view verb,
                                       std::span<const devices::ms2000::argument> args);
devices::ms2000::command typed_command(std::string_view verb,
                                       std::initializer_list<devices::ms2000::argument> args);
// The verb alone ("SCAN", "RM"). Coroutines call this one or a helper of their own: g++ 12 mishandles
// a braced argument list that lives across a co_await.
devices::ms2000::command typed_command(std::string_view verb);
// "TTL X=<mode>" as a command to send.
devices::ms2000::command ttl_in0(int mode);
// "TTL Y=1" / "TTL Y=0": the TTL output high or low.
devices::ms2000::command ttl_output(bool high);
// The line a command sends, without its CR: what previews, restore lists and messages show.
std::string text_of(const devices::ms2000::command& c);

// The command line without its CR ("SPEED X=0.528"); the bare verb when the arguments are refused.
std::string command_text(std::string_view verb, std::span<const devices::ms2000::argument> args);
std::string command_text(std::string_view verb, std::initializer_list<devices::ms2000::argument> args);

// "M X=<tenths> Y=<tenths>" for positions in micrometres; "M" when there are none.
std::string move_text(std::span<const devices::ms2000::axis_position> to);

// "TTL X=<mode>": the TTL input mode a scan or a ring-buffer run sets (and puts back).
std::string ttl_in0_command(int mode);

// "SPEED X? Y?": the query of `verb` for each letter of `letters`.
std::string query_text(std::string_view verb, std::string_view letters);

// The values a command line sets, by letter: "SPEED X=1.5 Y=2" is {X: 1.5, Y: 2} for verb "SPEED";
// empty for another verb's line. Reads a restore command back as the settings it puts back.
std::map<char, double> values_set(std::string_view line, std::string_view verb);

bool has_module(const devices::controller_snapshot& s, devices::ms2000::module m);
// The axis's hardware index (0 = first motor axis; SCAN Y=/Z= and RM Y= use it), -1 when absent.
int axis_index(const devices::controller_snapshot& s, char letter);
// The motor axes in hardware order ("XYZ"), for messages.
std::string motor_axes(const devices::controller_snapshot& s);

}  // namespace gw::jobs
