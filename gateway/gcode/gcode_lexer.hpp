#pragma once
// Splits one line of a G-code program into words. Pure: no I/O, no state between lines.
//   "N10 G01 X1.5 Y-.5 F300"  -> N10, G1, X1.5, Y-0.5, F300
//   "g1x1y2"                  -> G1, X1, Y2          (case-insensitive)
//   "Z- .1"                   -> Z-0.1               (blanks after the letter and the sign)
//   "G0 (move) X1 ; rest"     -> G0, X1              ("( )" comments; ';' ends the block)
//   "/G0 X5"                  -> block_delete, G0, X5
//   "%" / "% TITLE"           -> percent (tape start or end)
// Errors carry the line and the 1-based column of the offending character: a letter without a
// number, an unexpected character, a nested or unclosed comment, a blank inside a number
// ("X1 000"), a repeated letter in one block is NOT checked here (the interpreter does that).

#include <optional>
#include <string_view>
#include <vector>

#include "gateway/gcode/gcode_error.hpp"

namespace gw::gcode {

struct gcode_word {
    char letter = 'G';           // upper case
    double value = 0;            // as written, no unit conversion
    bool decimal_point = false;  // written with '.' ("X1." or "X.5")
    int column = 0;              // 1-based column of the letter
};

struct gcode_block {
    int line = 0;
    std::vector<gcode_word> words;       // in written order; an N word is always first
    bool block_delete = false;           // the block starts with '/'
    bool percent = false;                // a '%' line: tape start or end, no words
    int semicolon_column = 0;            // 1-based column of ';' (0: none)
    bool words_after_semicolon = false;  // what follows ';' looks like words (ignored: warn)

    void clear();
    const gcode_word* find(char letter) const;  // the first word with this letter, nullptr if none
};

// Lexes `text` (one line without its line end) into `out` (cleared first; its capacity is reused).
std::optional<gcode_error> lex_line(std::string_view text, int line, gcode_block& out);

// "'c'" for printable ASCII, "byte 0xNN" otherwise: error messages stay ASCII.
std::string describe_char(char c);

}  // namespace gw::gcode
