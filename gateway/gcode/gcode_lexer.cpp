#include "gateway/gcode/gcode_lexer.hpp"

#include <charconv>
#include <cstddef>
#include <cstdio>
#include <string>
#include <system_error>

namespace gw::gcode {

namespace {

constexpr std::size_t max_number_chars = 48;

bool is_blank(char c) {
    return c == ' ' || c == '\t';
}
bool is_digit(char c) {
    return c >= '0' && c <= '9';
}
bool is_letter(char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z');
}
char upper(char c) {
    return (c >= 'a' && c <= 'z') ? static_cast<char>(c - 'a' + 'A') : c;
}

gcode_error at(int line, std::size_t index, std::string message) {
    return gcode_error{line, static_cast<int>(index) + 1, std::move(message)};
}

// Text after ';': a letter followed (blanks allowed) by a sign, a digit or a '.' outside comments.
bool looks_like_words(std::string_view rest) {
    int depth = 0;
    for (std::size_t i = 0; i < rest.size(); ++i) {
        const char c = rest[i];
        if (c == '(') ++depth;
        if (c == ')' && depth > 0) --depth;
        if (depth > 0 || !is_letter(c)) continue;
        std::size_t j = i + 1;
        while (j < rest.size() && is_blank(rest[j]))
            ++j;
        if (j < rest.size() && (is_digit(rest[j]) || rest[j] == '-' || rest[j] == '+' || rest[j] == '.'))
            return true;
    }
    return false;
}

}  // namespace

std::string describe_char(char c) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x21 && u < 0x7f) return std::string("'") + c + "'";
    char buf[16];
    std::snprintf(buf, sizeof buf, "byte 0x%02X", static_cast<unsigned>(u));
    return buf;
}

void gcode_block::clear() {
    line = 0;
    words.clear();
    block_delete = false;
    percent = false;
    semicolon_column = 0;
    words_after_semicolon = false;
}

const gcode_word* gcode_block::find(char letter) const {
    for (const auto& w : words)
        if (w.letter == letter) return &w;
    return nullptr;
}

std::optional<gcode_error> lex_line(std::string_view text, int line, gcode_block& out) {
    out.clear();
    out.line = line;
    std::size_t i = 0;
    const std::size_t n = text.size();
    while (i < n && is_blank(text[i]))
        ++i;
    if (i < n && text[i] == '%') {
        out.percent = true;
        return std::nullopt;
    }
    if (i < n && text[i] == '/') {
        out.block_delete = true;
        ++i;
    }
    while (i < n) {
        const char c = text[i];
        if (is_blank(c)) {
            ++i;
            continue;
        }
        if (c == '(') {
            const std::size_t open = i;
            ++i;
            while (i < n && text[i] != ')') {
                if (text[i] == '(')
                    return at(line, i,
                              "nested comment: '(' inside the comment opened at column " +
                                  std::to_string(open + 1));
                ++i;
            }
            if (i >= n) return at(line, open, "unclosed comment: '(' without ')'");
            ++i;
            continue;
        }
        if (c == ';') {
            out.semicolon_column = static_cast<int>(i) + 1;
            out.words_after_semicolon = looks_like_words(text.substr(i + 1));
            return std::nullopt;
        }
        if (c == ')') return at(line, i, "')' without '('");
        if (!is_letter(c)) {
            if (is_digit(c) || c == '.' || c == '-' || c == '+') {
                if (!out.words.empty() && i > 0 && is_blank(text[i - 1]))
                    return at(line, i, "blank inside a number, or a number without a letter");
                return at(line, i, "number without a letter");
            }
            return at(line, i, "unexpected character " + describe_char(c));
        }
        gcode_word w;
        w.letter = upper(c);
        w.column = static_cast<int>(i) + 1;
        const std::size_t letter_at = i;
        ++i;
        // The number: blanks may follow the letter and the sign ("Z- .1"), not sit between digits.
        char buf[max_number_chars + 1];
        std::size_t len = 0;
        bool digits = false;
        while (i < n && is_blank(text[i]))
            ++i;
        if (i < n && (text[i] == '-' || text[i] == '+')) {
            if (text[i] == '-') buf[len++] = '-';
            ++i;
            while (i < n && is_blank(text[i]))
                ++i;
        }
        while (i < n && (is_digit(text[i]) || text[i] == '.')) {
            if (text[i] == '.') {
                if (w.decimal_point)
                    return at(line, i, std::string("second '.' in the number of ") + w.letter);
                w.decimal_point = true;
            } else {
                digits = true;
            }
            if (len >= max_number_chars)
                return at(line, letter_at, std::string("number of ") + w.letter + " too long");
            buf[len++] = text[i];
            ++i;
        }
        if (!digits) {
            if (i < n && !is_blank(text[i]))
                return at(line, letter_at,
                          std::string(1, w.letter) + " needs a number, found " + describe_char(text[i]));
            return at(line, letter_at, std::string(1, w.letter) + " needs a number");
        }
        const char* first = buf;
        const char* last = buf + len;
        // from_chars does not take "5." or ".5" forms everywhere the same way: normalise them.
        std::string normalised(first, last);
        if (normalised.back() == '.') normalised.push_back('0');
        const std::size_t dot = normalised.find('.');
        if (dot != std::string::npos && (dot == 0 || !is_digit(normalised[dot - 1])))
            normalised.insert(dot, 1, '0');
        const auto [end, ec] =
            std::from_chars(normalised.data(), normalised.data() + normalised.size(), w.value);
        if (ec != std::errc{} || end != normalised.data() + normalised.size())
            return at(line, letter_at, std::string("bad number for ") + w.letter);
        if (w.value == 0) w.value = 0;  // no negative zero
        if (w.letter == 'N' && !out.words.empty())
            return at(line, letter_at, "N must be the first word of a block");
        out.words.push_back(w);
    }
    return std::nullopt;
}

}  // namespace gw::gcode
