#pragma once
// How accepted replies change a controller's snapshot. Pure: no I/O, no clock. The driver calls these
// with replies that passed ms2000::accept_reply (so every string in them is printable ASCII); the
// controller-data fuzz target drives them with whatever survives that test.

#include <cstddef>
#include <optional>
#include <string_view>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/reply.hpp"
#include "devices/serial/controller_snapshot.hpp"

namespace gw::devices {

// V: a fresh identity with the version.
void apply_version(controller_snapshot& s, const ms2000::reply& r);
// BU X (nullptr if the firmware refused it): build, axes in hardware order. False if no motor axes
// were listed and the smallest MS-2000, an XY stage, was assumed.
bool apply_build(controller_snapshot& s, const ms2000::reply* r);
// CNTS, SL, SU, S, AC, B, OS: one number per axis into `field` of each axis_state.
void apply_axis_numbers(controller_snapshot& s, const ms2000::reply& r,
                        std::optional<double> axis_state::*field);
// PC: the finish error of each axis, and the step it was printed with.
void apply_finish_errors(controller_snapshot& s, const ms2000::reply& r);
// The answer to a motion setting query (S, AC, PC, B, OS: motion_setting_verbs) into its field.
inline constexpr std::string_view motion_setting_verbs[] = {"S", "AC", "PC", "B", "OS"};
void apply_motion_setting(controller_snapshot& s, std::string_view verb, const ms2000::reply& r);
// The motion setting a command sets ("S X=2" -> "S", "BACKLASH X=0" -> "B"); empty when it sets none.
std::string_view motion_setting_set_by(const ms2000::command& cmd);
// TTL X? Y?: the IN0 and OUT0 modes, named or positional.
void apply_ttl_modes(controller_snapshot& s, const ms2000::reply& r);
// W <axes>: positions in hardware order, tenths of a micron.
void apply_where(controller_snapshot& s, const ms2000::reply& r);
// RS <axis>?: whether that axis is busy.
void apply_axis_busy(controller_snapshot& s, std::size_t axis_index, const ms2000::reply& r);
// "/": whether the stage moves; when it does not, no axis does (which axes move is for RS to say).
void apply_busy(controller_snapshot& s, bool busy);

}  // namespace gw::devices
