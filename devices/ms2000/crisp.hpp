#pragma once
// CRISP, the controller's continuous focus lock ("LK", LOCK), and AUTOFOCUS ("AF"): their commands
// and the readings of their replies (doc §3.12). Pure.
//
//   LK X?   -> ":A F"        state letter, no trailing space
//   LK Y?   -> ":A -1234 "   focus error (signed, the LCD's unit)
//   LK T?   -> ":A 2400 "    sum (reflected light)
//   LK Z?   -> ":A Z=20 "    lock offset; LK Z=<n> sets it
//   LK F=83 / 85 / 79        lock ('S') / unlock to ready ('U') / LED off, idle ('O')
//   EX Y?   -> ":A 20.5 "    signal-to-noise ratio, firmware 9.53 and later (EXTRA Y? before)
//   AF                       start a focus scan; AF X? -> ":A 1" while it runs (our reading)

#include <optional>
#include <string_view>

#include <boost/system/result.hpp>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/reply.hpp"

namespace gw::devices::ms2000 {

// The largest |lock offset| the gateway sends: the focus error's range on the LCD.
inline constexpr double max_crisp_offset = 32767;

// What a state letter of "LK X?" means, in snake case: 'F' -> "locked", 'K' -> "trying_to_lock";
// "unknown" for a letter MM-Stage does not map (doc §3.12).
std::string_view crisp_state_name(char state);

// Whether the lock holds ('F') or is being acquired ('K').
bool crisp_locking_or_locked(char state);

command crisp_state_query();                                     // "LK X?"
command crisp_focus_error_query();                               // "LK Y?"
command crisp_sum_query();                                       // "LK T?"
command crisp_offset_query();                                    // "LK Z?"
command crisp_lock();                                            // "LK F=83"
command crisp_unlock();                                          // "LK F=85"
command crisp_off();                                             // "LK F=79"
boost::system::result<command> crisp_set_offset(double offset);  // "LK Z=20"; |offset| <= max
// "EX Y?" on 9.53 and later, "EXTRA Y?" before; nullopt when the version cannot be read.
std::optional<command> crisp_snr_query(std::string_view firmware_version);

command autofocus_start();  // "AF"
command autofocus_query();  // "AF X?"

// The state letter of an "LK X?" answer: one printable letter; nullopt otherwise.
std::optional<char> crisp_state_of(const reply& r);

// The one number of an answer in either form the controller uses for a single reading: ":A 12" or
// ":A Z=12"; nullopt for anything else.
std::optional<double> single_reading(const reply& r);

}  // namespace gw::devices::ms2000
