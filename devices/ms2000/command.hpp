#pragma once
// Builds MS-2000 command lines. Pure: no I/O. The only place where wire text for commands is made.
// Every argument is checked: no CR, LF or other control byte can reach the serial line, numbers
// must be finite, axis letters must be letters. Positions are given in micrometres and sent in the
// controller's unit, tenths of a micron ("M X=1234.5" moves X to 123.45 um).

#include <cstdint>
#include <initializer_list>
#include <span>
#include <string>
#include <string_view>

#include <boost/system/result.hpp>

namespace gw::devices::ms2000 {

// The shape of reply a command expects; parse_reply() needs it because "/" answers "N"/"B".
enum class reply_shape : std::uint8_t {
    standard,   // ":A", ":A <values>", ":A X=..", ":X=.. A", "X=.. :A", or ":N-<code>"
    status,     // "N" or "B" (STATUS, "/")
    multiline,  // CR-separated lines ending CR LF (BUILD X, INFO, WHO); ":N-<code>" is still an error
    two_phase,  // SAVESET "SS Z": ":" at once, "A" + CR LF when the flash write is done
    // RDSBYTE "RB X Y": ":" then each axis's status byte as one raw byte, CR LF; ":N-<code>" is an
    // error. The bytes may be CR or LF, so the line framer is told how many to take (line_framer).
    status_bytes,
};

// What a reply must hold to be taken as the answer to its command, beyond its shape. A reply of the
// right shape but the wrong content ("W X Y" answered ":A 1234.5", a move answered ":A 12 34") is
// another command's reply or noise: the driver fails the command and resynchronises the link. An
// error reply ":N-<code>" fits every command. Inferred from the verb and its arguments by every
// builder (raw lines too), so a command of a verb whose reply is not known gets kind::any.
struct reply_form {
    enum class kind : std::uint8_t {
        any,           // the shape alone
        bare_ack,      // ":A" with nothing after it: moves, HERE, ZERO, HOME, HALT
        numbers,       // ":A" then exactly one number per letter of `axes` (WHERE)
        axis_values,   // "L=value" for every letter of `axes` (parameter queries "S X? Y?")
        version,       // ":A Version: USB-9.52" or ":A v9.54" (VERSION)
        build_text,    // the multi-line BUILD X text, not a one-line ":A .." reply
        integers,      // ":A" then any number of integers, none "L=": the error log (DU Y)
        status_bytes,  // ":" then one raw byte per letter of `axes` (RDSBYTE)
    };
    kind what = kind::any;
    std::string axes;  // upper-case letters in request order (numbers, axis_values)
    // axis_values only: the firmware may answer positionally, one token per axis (":A 0 0" for
    // "TTL X? Y?") or one character per axis with no space (":A NB" for "RS X? Y?").
    bool positional = false;
};

struct command {
    std::string verb;  // as sent, upper case: "W", "MOVE", "\\", "SS"
    std::string wire;  // the exact bytes to write, ending with CR
    reply_shape expect = reply_shape::standard;
    reply_form form;          // what the reply must contain (see reply_form)
    bool is_halt = false;     // HALT jumps the driver's queue
    bool long_reply = false;  // multiline or two_phase: the driver uses its longer timeout
};

// One argument: "X", "X=1.5", "X?", "X+", "X-". `axis` is any letter (axes X Y Z F, but also the
// parameter letters of ARRAY, RM, SCANR, TTL, ...); it is sent upper case.
struct argument {
    enum class op : std::uint8_t { bare, set, query, plus, minus };
    char axis = 'X';
    op kind = op::bare;
    double value = 0;  // for op::set; sent with up to `decimals` decimals, trailing zeros dropped
    int decimals = 4;
};

struct axis_position {
    char axis = 'X';
    double micrometres = 0;
};

// Generic builder: "<VERB> <arg> <arg>\r". The verb must be 1..12 characters of [A-Z0-9] or one of
// the single-character commands / \ ! @ ~; anything else is error::invalid_argument.
boost::system::result<command> make_command(std::string_view verb, std::span<const argument> args,
                                            reply_shape expect = reply_shape::standard);

// One line typed by an expert ("W X Y"): printable ASCII only (0x20..0x7E), at most
// max_raw_command_bytes, no CR/LF anywhere (a single trailing CR is not accepted either: the builder
// adds it). The reply shape is inferred from the verb (/, STATUS -> status; BU X, INFO, WHO ->
// multiline; SS Z -> two_phase). RDSBYTE ("RB") is refused with error::binary_reply: its answer is raw
// bytes, not text (RDSTAT "RS X" gives the same byte in ASCII).
inline constexpr std::size_t max_raw_command_bytes = 256;
boost::system::result<command> raw_command(std::string_view line);

// One line from a program that speaks to the controller itself (a shared port's client), sent exactly
// as it came with a CR added: the firmware's own parser decides, since clients in the wild send forms
// the manual does not show ("w x", "MOVE X=1"). Printable ASCII only, at most max_raw_command_bytes,
// a first word the controller could read as a verb. Reply shape and form are inferred from the
// upper-cased verb as for raw_command. RDSBYTE ("RB X Y") is taken too: its answer of raw bytes goes
// back to the program as it came (raw_command refuses it: a JSON reply cannot carry those bytes).
boost::system::result<command> verbatim_command(std::string_view line);

// What a command may do to the controller, for deciding who may send it (a shared port's role).
enum class command_effect : std::uint8_t {
    reads,         // only reads (only_reads)
    halts,         // HALT
    acts,          // moves, or changes a setting the controller keeps in memory (a verb the tables know)
    writes_flash,  // SAVESET, SAVEPOS: outlives a power cycle
    breaks_link,   // RESET, BAUD: the gateway's own link to the controller ends
    unknown,       // a verb the protocol tables do not know: may do anything
};
command_effect effect_of(const command& cmd);
const char* to_string(command_effect effect);

// True when the command only reads the controller (WHERE, STATUS, RS, RB, VERSION, BUILD, WHO, INFO, or
// parameter queries whose every argument is "L?"): it cannot start a move or change a setting. The
// driver polls less often while the stage is idle and nothing but such commands ran.
bool only_reads(const command& cmd);

// Why the command resets the controller or changes the calibration the gateway reads at identification
// ("" when it does not): RESET / "~", "SS X" (factory defaults at the next power-up), a unit
// multiplier or encoder count set ("UM X=..", "CNTS X=.."), a baud rate (BAUD). Such a raw command
// needs the caller to insist, and is followed by a new identification.
std::string_view resets_or_recalibrates(const command& cmd);

// Formats a number the way the controller reads it: fixed notation, at most `decimals` decimals,
// trailing zeros and a trailing dot dropped, "-0" printed as "0". Empty result for NaN or infinity.
std::string format_number(double value, int decimals);

// Typed builders; the comment quotes the wire form.
command status();                                                                 // "/"
command halt();                                                                   // "\"
command where(std::string_view axes);                                             // "W X Y Z"
command version();                                                                // "V"
command build_x();                                                                // "BU X"
command who();                                                                    // "WHO"
command query(std::string_view verb, std::string_view axes);                      // "CNTS X? Y?"
boost::system::result<command> move(std::span<const axis_position> to);           // "M X=1234.5 Y=-10"
boost::system::result<command> move_relative(std::span<const axis_position> by);  // "R X=10"
boost::system::result<command> here(std::span<const axis_position> at);           // "H X=0 Y=0"
// The same with a braced list: move({{'X', 123.45}}). Call move() qualified (ms2000::move) when the
// argument is a std::vector: argument-dependent lookup would otherwise find std::move.
boost::system::result<command> move(std::initializer_list<axis_position> to);
boost::system::result<command> move_relative(std::initializer_list<axis_position> by);
boost::system::result<command> here(std::initializer_list<axis_position> at);
command zero();                       // "Z"
command home(std::string_view axes);  // "! X Y"
command save_settings();              // "SS Z" (two_phase)

}  // namespace gw::devices::ms2000
