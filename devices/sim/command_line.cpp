#include "devices/sim/command_line.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <utility>

#include <boost/system/errc.hpp>

namespace gw::devices::sim {

namespace {

using errc = boost::system::errc::errc_t;

boost::system::error_code make(errc e) {
    return boost::system::errc::make_error_code(e);
}

// Short form -> full name (doc §3; EMU's shortcut table where ASI pages give none).
constexpr std::pair<std::string_view, std::string_view> aliases[] = {
    {"M", "MOVE"},     {"R", "MOVREL"},   {"W", "WHERE"},   {"H", "HERE"},      {"Z", "ZERO"},
    {"!", "HOME"},     {"HM", "SETHOME"}, {"\\", "HALT"},   {"/", "STATUS"},    {"RS", "RDSTAT"},
    {"RB", "RDSBYTE"}, {"@", "SPIN"},     {"VE", "VECTOR"}, {"S", "SPEED"},     {"AC", "ACCEL"},
    {"B", "BACKLASH"}, {"PC", "PCROS"},   {"E", "ERROR"},   {"WT", "WAIT"},     {"OS", "OVERSHOOT"},
    {"AA", "AALIGN"},  {"AZ", "AZERO"},   {"SU", "SETUP"},  {"SL", "SETLOW"},   {"MC", "MOTCTRL"},
    {"J", "JOYSTICK"}, {"JS", "JSSPD"},   {"C", "CNTS"},    {"CCA", "CUSTOMA"}, {"CCB", "CUSTOMB"},
    {"LD", "LOAD"},    {"RM", "RBMODE"},  {"NR", "SCANR"},  {"NV", "SCANV"},    {"SN", "SCAN"},
    {"AH", "AHOME"},   {"IJ", "AIJ"},     {"AR", "ARRAY"},  {"RT", "RTIME"},    {"SS", "SAVESET"},
    {"SP", "SAVEPOS"}, {"BU", "BUILD"},   {"V", "VERSION"}, {"CD", "CDATE"},    {"N", "WHO"},
    {"I", "INFO"},     {"DU", "DUMP"},    {"~", "RESET"},   {"UN", "UNITS"},    {"RA", "RDADC"},
    {"LK", "LOCK"},    {"AF", "AFOCUS"},  {"EX", "EXTRA"},  {"ST", "STATUS"},   {"O", "OVERSHOOT"},
};

bool is_space(char c) {
    return c == ' ' || c == '\t';
}

bool single_char_verb(char c) {
    return c == '/' || c == '\\' || c == '!' || c == '@' || c == '~';
}

boost::system::result<line_argument> parse_argument(std::string_view token) {
    line_argument arg;
    const auto letter = static_cast<unsigned char>(token.front());
    if (!std::isalpha(letter)) return make(errc::invalid_argument);
    arg.letter = static_cast<char>(std::toupper(letter));
    auto rest = token.substr(1);
    if (rest.empty()) return arg;  // bare: a number-taking command reads 0
    if (rest == "?") {
        arg.kind = line_argument::op::query;
        return arg;
    }
    if (rest == "+" || rest == "-") {
        arg.kind = rest == "+" ? line_argument::op::plus : line_argument::op::minus;
        return arg;
    }
    if (rest.front() != '=') return make(errc::invalid_argument);
    arg.kind = line_argument::op::set;
    rest.remove_prefix(1);
    if (!rest.empty() && rest.back() == '?') {
        arg.also_query = true;
        rest.remove_suffix(1);
    }
    if (rest.empty()) return arg;  // "X=" -> 0
    // from_chars rejects a leading '+', which people type.
    if (rest.front() == '+') rest.remove_prefix(1);
    double value = 0;
    const auto [end, ec] = std::from_chars(rest.data(), rest.data() + rest.size(), value);
    if (ec != std::errc{} || end != rest.data() + rest.size()) return make(errc::invalid_argument);
    arg.value = value;
    arg.has_number = true;
    return arg;
}

}  // namespace

const line_argument* command_line::find(char letter) const {
    const char upper = static_cast<char>(std::toupper(static_cast<unsigned char>(letter)));
    for (const auto& a : args)
        if (a.letter == upper) return &a;
    return nullptr;
}

bool command_line::has_query() const {
    return std::any_of(args.begin(), args.end(), [](const line_argument& a) {
        return a.kind == line_argument::op::query || a.also_query;
    });
}

std::string canonical_verb(std::string_view typed_upper) {
    for (const auto& [alias, full] : aliases)
        if (alias == typed_upper) return std::string(full);
    return std::string(typed_upper);
}

boost::system::result<command_line> parse_command_line(std::string_view line) {
    std::size_t i = 0;
    while (i < line.size() && is_space(line[i]))
        ++i;
    if (i == line.size()) return make(errc::no_message);
    command_line out;
    if (single_char_verb(line[i])) {
        out.typed = std::string(1, line[i]);
        ++i;
    } else {
        const auto start = i;
        while (i < line.size() && !is_space(line[i]))
            ++i;
        for (auto c : line.substr(start, i - start))
            out.typed.push_back(static_cast<char>(std::toupper(static_cast<unsigned char>(c))));
    }
    out.verb = canonical_verb(out.typed);
    while (true) {
        while (i < line.size() && is_space(line[i]))
            ++i;
        if (i == line.size()) break;
        const auto start = i;
        while (i < line.size() && !is_space(line[i]))
            ++i;
        const auto token = line.substr(start, i - start);
        // Axis letters run together ("W XYZ") are read one by one, as the firmware's parser reads
        // characters: mesoSPIM sends "W XYZ" and reads the values in hardware order (devices/sim/README.md,
        // "Third-party drivers").
        if (token.size() > 1 && std::all_of(token.begin(), token.end(), [](char c) {
                return std::isalpha(static_cast<unsigned char>(c)) != 0;
            })) {
            for (char c : token)
                out.args.push_back({static_cast<char>(std::toupper(static_cast<unsigned char>(c)))});
            continue;
        }
        auto arg = parse_argument(token);
        if (!arg) return arg.error();
        out.args.push_back(*arg);
    }
    return out;
}

}  // namespace gw::devices::sim
