#pragma once
// Parses one incoming command line (without its CR) the way the MS-2000 reads it. Pure.
//   "M X=1.5 Y"          -> MOVE, {X set 1.5, Y set 0}   (missing number = 0, doc §1)
//   "scanr x=0 y=1 z=24" -> SCANR, three set arguments   (case-insensitive)
//   "RS X?"              -> RDSTAT, {X query}
//   "LED X=50?"          -> LED, {X set 50 + query}      (QUDI sends a set with a stray '?')
//   "RT M+"  "J X-"      -> plus / minus
//   "/"  "\"  "! X Y"    -> single-character verbs, also when glued to the first argument
// Aliases are resolved to the full command name ("M" -> "MOVE", "NR" -> "SCANR").

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <boost/system/result.hpp>

namespace gw::devices::sim {

struct line_argument {
    enum class op : std::uint8_t { bare, set, query, plus, minus };
    char letter = 'X';  // upper case
    op kind = op::bare;
    double value = 0;         // set: the number ("X=" and bare give 0)
    bool has_number = false;  // set with digits after '='
    bool also_query = false;  // "X=50?"
};

struct command_line {
    std::string verb;   // canonical upper-case name: "MOVE", "STATUS", "HALT", ...
    std::string typed;  // the verb as typed, upper case ("M")
    std::vector<line_argument> args;

    const line_argument* find(char letter) const;
    bool has_query() const;
};

// The canonical name for a typed verb (upper case), or the verb itself when it has no alias.
std::string canonical_verb(std::string_view typed_upper);

// errc::invalid_argument for an argument that is not LETTER[=number][?|+|-] or a bad number;
// errc::no_message for an empty (blank) line.
boost::system::result<command_line> parse_command_line(std::string_view line);

}  // namespace gw::devices::sim
