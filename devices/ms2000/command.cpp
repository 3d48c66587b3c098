#include "devices/ms2000/command.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <vector>

#include "devices/ms2000/ascii.hpp"
#include "devices/ms2000/error.hpp"

namespace gw::devices::ms2000 {

namespace {

constexpr std::size_t max_verb_chars = 12;
// Keeps the wire short and std::to_chars' fixed output small: no stage travels 10^12 tenths of a micron.
constexpr double max_abs_value = 1e12;
constexpr int max_decimals = 9;

bool is_upper_alnum(char c) {
    return (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9');
}
bool is_single_char_verb(char c) {
    return c == '/' || c == '\\' || c == '!' || c == '@' || c == '~';
}

std::string upper(std::string_view text) {
    std::string out(text);
    std::transform(out.begin(), out.end(), out.begin(), ascii_upper);
    return out;
}

// The verb as sent (upper case), or empty when it is not a verb the controller could read.
std::string checked_verb(std::string_view verb) {
    if (verb.size() == 1 && is_single_char_verb(verb[0])) return std::string(verb);
    if (verb.empty() || verb.size() > max_verb_chars) return {};
    std::string out = upper(verb);
    if (!std::all_of(out.begin(), out.end(), is_upper_alnum)) return {};
    return out;
}

bool is_halt_verb(std::string_view verb) {
    return verb == "\\" || verb == "HALT";
}

std::vector<std::string> upper_words(std::string_view text) {
    std::vector<std::string> words;
    while (!text.empty()) {
        const auto start = text.find_first_not_of(' ');
        if (start == std::string_view::npos) break;
        text.remove_prefix(start);
        const auto end = std::min(text.find(' '), text.size());
        words.push_back(upper(text.substr(0, end)));
        text.remove_prefix(end);
    }
    return words;
}

bool is_one_of(std::string_view verb, std::initializer_list<std::string_view> verbs) {
    return std::find(verbs.begin(), verbs.end(), verb) != verbs.end();
}

// The letters of arguments that are all "L" (suffix '\0') or all "L?" (suffix '?'); empty otherwise.
std::string letters_if_all(const std::vector<std::string>& words, char suffix) {
    std::string letters;
    for (const std::string& w : words) {
        const bool bare = w.size() == 1 && suffix == '\0';
        const bool query = w.size() == 2 && suffix != '\0' && w[1] == suffix;
        if (!is_ascii_letter(w[0]) || !(bare || query)) return {};
        letters.push_back(w[0]);
    }
    return letters;
}

// The axis letters of "X Y Z" or "XYZ" (the firmware reads letters run together one by one); empty when
// any word is something else ("X=1", "X?"), whose answer the count of letters cannot predict.
std::string axis_letters(std::string_view args) {
    std::string letters;
    for (const std::string& w : upper_words(args)) {
        if (!std::all_of(w.begin(), w.end(), is_ascii_letter)) return {};
        letters += w;
    }
    return letters;
}

// What the wire says after the verb, without the closing CR: " X? Y?" of "RS X? Y?\r".
std::string_view arguments_of(const command& cmd) {
    // A verbatim line may begin with spaces; built commands begin with their verb.
    auto args = std::string_view(cmd.wire);
    args.remove_prefix(std::min(args.find_first_not_of(' '), args.size()));
    args.remove_prefix(std::min(cmd.verb.size(), args.size()));
    if (args.ends_with('\r')) args.remove_suffix(1);
    return args;
}

}  // namespace

bool only_reads(const command& cmd) {
    if (is_one_of(cmd.verb,
                  {"W", "WHERE", "/", "STATUS", "RS", "RDSTAT", "RB", "RDSBYTE", "V", "VERSION", "WHO"}))
        return true;
    const auto words = upper_words(arguments_of(cmd));
    if (is_one_of(cmd.verb, {"BU", "BUILD", "INFO"})) return words.size() <= 1;
    return !words.empty() && !letters_if_all(words, '?').empty();
}

std::string_view resets_or_recalibrates(const command& cmd) {
    const auto args = arguments_of(cmd);
    const auto words = upper_words(args);
    const bool sets = args.find('=') != std::string_view::npos;
    if (is_one_of(cmd.verb, {"~", "RESET"}))
        return "RESET restarts the controller with its power-up settings";
    if (is_one_of(cmd.verb, {"SS", "SAVESET"}) &&
        std::any_of(words.begin(), words.end(), [](const std::string& w) { return w == "X"; }))
        return "SS X restores the factory settings at the next power-up";
    if (is_one_of(cmd.verb, {"UM"}) && sets) return "UM changes the unit of every position";
    if (is_one_of(cmd.verb, {"CNTS", "C"}) && sets) return "CNTS changes the encoder calibration";
    if (is_one_of(cmd.verb, {"BAUD"}) && sets) return "BAUD changes the serial line's speed";
    return {};
}

namespace {

// Every verb of the protocol reference (../shared/docs/ms2000-protocol.md, section 3), short and long.
constexpr std::string_view known_verbs[] = {
    "M",       "MOVE",  "R",       "MOVREL", "W",        "WHERE",     "H",     "HERE",    "Z",
    "ZERO",    "!",     "HOME",    "HM",     "SETHOME",  "\\",        "HALT",  "/",       "STATUS",
    "ST",      "RS",    "RDSTAT",  "RB",     "RDSBYTE",  "@",         "SPIN",  "VE",      "VECTOR",
    "S",       "SPEED", "AC",      "ACCEL",  "B",        "BACKLASH",  "PC",    "PCROS",   "E",
    "ERROR",   "WT",    "WAIT",    "OS",     "O",        "OVERSHOOT", "KP",    "KI",      "KD",
    "KV",      "AA",    "AALIGN",  "AZ",     "AZERO",    "SU",        "SETUP", "SL",      "SETLOW",
    "UM",      "MC",    "MOTCTRL", "J",      "JOYSTICK", "JS",        "JSSPD", "C",       "CNTS",
    "Z2B",     "CCA",   "CUSTOMA", "CCB",    "CUSTOMB",  "VB",        "LD",    "LOAD",    "RM",
    "RBMODE",  "NR",    "SCANR",   "NV",     "SCANV",    "SN",        "SCAN",  "AH",      "AHOME",
    "IJ",      "AIJ",   "AR",      "ARRAY",  "RT",       "RTIME",     "SS",    "SAVESET", "SP",
    "SAVEPOS", "BU",    "BUILD",   "V",      "VERSION",  "CD",        "CDATE", "N",       "WHO",
    "I",       "INFO",  "DU",      "DUMP",   "~",        "RESET",     "UN",    "UNITS",   "RA",
    "RDADC",   "LK",    "LOCK",    "AF",     "AFOCUS",   "EX",        "EXTRA", "TTL",     "LED",
    "UL",      "LR",    "AL",      "BAUD",   "PM",       "DAC",
};

}  // namespace

command_effect effect_of(const command& cmd) {
    if (cmd.is_halt) return command_effect::halts;
    if (only_reads(cmd)) return command_effect::reads;
    if (is_one_of(cmd.verb, {"~", "RESET", "BAUD"})) return command_effect::breaks_link;
    if (is_one_of(cmd.verb, {"SS", "SAVESET", "SP", "SAVEPOS"})) return command_effect::writes_flash;
    if (std::find(std::begin(known_verbs), std::end(known_verbs), cmd.verb) == std::end(known_verbs))
        return command_effect::unknown;
    return command_effect::acts;
}

const char* to_string(command_effect effect) {
    switch (effect) {
        case command_effect::reads:
            return "reads";
        case command_effect::halts:
            return "halts";
        case command_effect::acts:
            return "acts";
        case command_effect::writes_flash:
            return "writes-flash";
        case command_effect::breaks_link:
            return "breaks-link";
        case command_effect::unknown:
            return "unknown";
    }
    return "unknown";
}

namespace {

// Reply contents known from the protocol reference (../shared/docs/ms2000-protocol.md, sections 2.5
// to 2.7): WHERE, VERSION, BUILD X, the motion commands and the parameter queries of section 2.6.
// Everything else keeps kind::any, because a firmware may answer it in a shape not listed there.
reply_form infer_form(std::string_view verb, std::string_view args) {
    const std::vector<std::string> words = upper_words(args);
    reply_form form;
    if (is_one_of(verb, {"W", "WHERE"})) {
        form.axes = letters_if_all(words, '\0');
        if (!form.axes.empty()) form.what = reply_form::kind::numbers;
    } else if (is_one_of(verb, {"V", "VERSION"}) && words.empty()) {
        form.what = reply_form::kind::version;
    } else if (is_one_of(verb, {"BU", "BUILD"}) && words.size() == 1 && words[0] == "X") {
        form.what = reply_form::kind::build_text;
    } else if (is_one_of(verb, {"DU", "DUMP"}) && words.size() == 1 && words[0] == "Y") {
        form.what = reply_form::kind::integers;
    } else if (is_one_of(verb,
                         {"M", "MOVE", "R", "MOVREL", "H", "HERE", "Z", "ZERO", "!", "HOME", "\\", "HALT"})) {
        const bool queries = std::any_of(words.begin(), words.end(), [](const std::string& w) {
            return w.find('?') != std::string::npos;
        });
        if (!queries) form.what = reply_form::kind::bare_ack;
    } else if (is_one_of(verb,
                         {"S",    "SPEED",  "PC",    "OS",    "O",  "OVERSHOOT", "KP", "KI",       "KD",
                          "KV",   "AA",     "VE",    "HM",    "UL", "Z2B",       "LR", "AL",       "CNTS",
                          "SL",   "SETLOW", "SU",    "SETUP", "AC", "ACCEL",     "B",  "BACKLASH", "WT",
                          "WAIT", "E",      "ERROR", "LED",   "J",  "JOYSTICK"})) {
        form.axes = letters_if_all(words, '?');
        if (!form.axes.empty()) form.what = reply_form::kind::axis_values;
    } else if (is_one_of(verb, {"RB", "RDSBYTE"})) {
        form.axes = axis_letters(args);
        if (!form.axes.empty()) form.what = reply_form::kind::status_bytes;
    } else if (is_one_of(verb, {"TTL", "RS", "RDSTAT", "LK", "LOCK"})) {
        form.axes = letters_if_all(words, '?');
        if (!form.axes.empty()) {
            form.what = reply_form::kind::axis_values;
            form.positional = true;
        }
    }
    return form;
}

command finish(std::string verb, std::string wire, reply_shape expect) {
    command c;
    c.form = infer_form(verb, std::string_view(wire).substr(std::min(verb.size(), wire.size())));
    c.is_halt = is_halt_verb(verb);
    c.verb = std::move(verb);
    c.wire = std::move(wire);
    c.wire.push_back('\r');
    c.expect = expect;
    c.long_reply = expect == reply_shape::multiline || expect == reply_shape::two_phase;
    return c;
}

// "W X Y Z" from "XYZ" or "X Y Z": only letters are used, so nothing else can reach the wire.
command verb_with_axes(std::string verb, std::string_view axes, std::string_view suffix,
                       reply_shape expect = reply_shape::standard) {
    std::string wire = verb;
    for (char c : axes) {
        if (!is_ascii_letter(c)) continue;
        wire.push_back(' ');
        wire.push_back(ascii_upper(c));
        wire.append(suffix);
    }
    return finish(std::move(verb), std::move(wire), expect);
}

boost::system::result<command> positions(std::string_view verb, std::span<const axis_position> list) {
    if (list.empty()) return make_error_code(error::invalid_argument);
    std::vector<argument> args;
    args.reserve(list.size());
    for (const axis_position& p : list) {
        const char axis = ascii_upper(p.axis);
        for (const argument& earlier : args) {
            if (earlier.axis == axis) return make_error_code(error::invalid_argument);  // "M X=1 X=2"
        }
        // Micrometres to the controller's tenths of a micron; 3 decimals is far below encoder resolution.
        args.push_back({axis, argument::op::set, p.micrometres * 10.0, 3});
    }
    return make_command(verb, args);
}

// Upper-cased first word of the arguments ("x" of " x=1"), leading spaces skipped.
std::string first_word(std::string_view args) {
    const auto start = args.find_first_not_of(' ');
    if (start == std::string_view::npos) return {};
    args.remove_prefix(start);
    return upper(args.substr(0, std::min(args.find(' '), args.size())));
}

reply_shape infer_shape(std::string_view verb, std::string_view args) {
    const std::string first = first_word(args);
    if (verb == "/" || verb == "STATUS") return reply_shape::status;
    // "BU" answers the bare build name, "BU X" the multi-line list; "BU Y?"/"BU Z?" answer ":A ..".
    if ((verb == "BU" || verb == "BUILD") && (first.empty() || first == "X")) return reply_shape::multiline;
    if (verb == "INFO" || verb == "I" || verb == "WHO" || verb == "N") return reply_shape::multiline;
    if ((verb == "SS" || verb == "SAVESET") && first == "Z") return reply_shape::two_phase;
    if ((verb == "RB" || verb == "RDSBYTE") && !axis_letters(args).empty()) return reply_shape::status_bytes;
    return reply_shape::standard;
}

}  // namespace

std::string format_number(double value, int decimals) {
    if (!std::isfinite(value)) return {};
    decimals = std::clamp(decimals, 0, max_decimals);
    // Fixed notation of a double needs at most 309 integer digits, the sign and the decimals.
    std::array<char, 352> buffer{};
    const auto [end, ec] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value,
                                         std::chars_format::fixed, decimals);
    if (ec != std::errc{}) return {};
    std::string text(buffer.data(), end);
    if (text.find('.') != std::string::npos) {
        while (text.back() == '0')
            text.pop_back();
        if (text.back() == '.') text.pop_back();
    }
    if (text == "-0") text = "0";
    return text;
}

boost::system::result<command> make_command(std::string_view verb, std::span<const argument> args,
                                            reply_shape expect) {
    std::string checked = checked_verb(verb);
    if (checked.empty()) return make_error_code(error::invalid_argument);
    std::string wire = checked;
    for (const argument& a : args) {
        if (!is_ascii_letter(a.axis)) return make_error_code(error::invalid_argument);
        wire.push_back(' ');
        wire.push_back(ascii_upper(a.axis));
        switch (a.kind) {
            case argument::op::bare:
                break;
            case argument::op::query:
                wire.push_back('?');
                break;
            case argument::op::plus:
                wire.push_back('+');
                break;
            case argument::op::minus:
                wire.push_back('-');
                break;
            case argument::op::set: {
                if (!std::isfinite(a.value) || std::fabs(a.value) > max_abs_value || a.decimals < 0 ||
                    a.decimals > max_decimals) {
                    return make_error_code(error::invalid_argument);
                }
                wire.push_back('=');
                wire += format_number(a.value, a.decimals);
                break;
            }
            default:
                return make_error_code(error::invalid_argument);
        }
    }
    return finish(std::move(checked), std::move(wire), expect);
}

namespace {

// A line typed by a person or a program: its upper-cased verb and what follows it, spaces around
// trimmed. Printable ASCII only, at most max_raw_command_bytes, a verb the controller could read.
struct typed_line {
    std::string verb;
    std::string_view args;
};

boost::system::result<typed_line> read_typed_line(std::string_view line) {
    if (line.empty() || line.size() > max_raw_command_bytes) return make_error_code(error::invalid_argument);
    for (char c : line) {
        const auto byte = static_cast<unsigned char>(c);
        if (byte < 0x20 || byte > 0x7E) return make_error_code(error::invalid_argument);
    }
    const auto start = line.find_first_not_of(' ');
    if (start == std::string_view::npos) return make_error_code(error::invalid_argument);
    std::string_view rest = line.substr(start);
    while (!rest.empty() && rest.back() == ' ')
        rest.remove_suffix(1);
    // "/" and "\" may be followed directly by arguments; other verbs end at the first space.
    const std::size_t verb_end = is_single_char_verb(rest[0]) ? 1 : std::min(rest.find(' '), rest.size());
    std::string verb = checked_verb(rest.substr(0, verb_end));
    if (verb.empty()) return make_error_code(error::invalid_argument);
    return typed_line{std::move(verb), rest.substr(verb_end)};
}

}  // namespace

boost::system::result<command> raw_command(std::string_view line) {
    auto typed = read_typed_line(line);
    if (!typed) return typed.error();
    if (typed->verb == "RB" || typed->verb == "RDSBYTE") return make_error_code(error::binary_reply);
    std::string wire = typed->verb;
    wire.append(typed->args);
    const reply_shape expect = infer_shape(typed->verb, typed->args);
    return finish(std::move(typed->verb), std::move(wire), expect);
}

boost::system::result<command> verbatim_command(std::string_view line) {
    auto typed = read_typed_line(line);
    if (!typed) return typed.error();
    command c;
    c.form = infer_form(typed->verb, typed->args);
    c.expect = infer_shape(typed->verb, typed->args);
    c.long_reply = c.expect == reply_shape::multiline || c.expect == reply_shape::two_phase;
    c.is_halt = is_halt_verb(typed->verb);
    c.verb = std::move(typed->verb);
    c.wire.assign(line);
    c.wire.push_back('\r');
    return c;
}

command status() {
    return finish("/", "/", reply_shape::status);
}
command halt() {
    return finish("\\", "\\", reply_shape::standard);
}
command where(std::string_view axes) {
    return verb_with_axes("W", axes, "");
}
command version() {
    return finish("V", "V", reply_shape::standard);
}
command build_x() {
    return finish("BU", "BU X", reply_shape::multiline);
}
command who() {
    return finish("WHO", "WHO", reply_shape::multiline);
}

command query(std::string_view verb, std::string_view axes) {
    // The verb comes from code, not from a user; characters that could not be a verb are dropped.
    std::string checked;
    for (char c : verb) {
        if (is_upper_alnum(ascii_upper(c)) && checked.size() < max_verb_chars)
            checked.push_back(ascii_upper(c));
    }
    if (verb.size() == 1 && is_single_char_verb(verb[0])) checked.assign(verb);
    return verb_with_axes(std::move(checked), axes, "?");
}

boost::system::result<command> move(std::span<const axis_position> to) {
    return positions("M", to);
}
boost::system::result<command> move_relative(std::span<const axis_position> by) {
    return positions("R", by);
}
boost::system::result<command> here(std::span<const axis_position> at) {
    return positions("H", at);
}
boost::system::result<command> move(std::initializer_list<axis_position> to) {
    return positions("M", std::span<const axis_position>(to.begin(), to.size()));
}
boost::system::result<command> move_relative(std::initializer_list<axis_position> by) {
    return positions("R", std::span<const axis_position>(by.begin(), by.size()));
}
boost::system::result<command> here(std::initializer_list<axis_position> at) {
    return positions("H", std::span<const axis_position>(at.begin(), at.size()));
}
command zero() {
    return finish("Z", "Z", reply_shape::standard);
}
command home(std::string_view axes) {
    return verb_with_axes("!", axes, "");
}
command save_settings() {
    return finish("SS", "SS Z", reply_shape::two_phase);
}

}  // namespace gw::devices::ms2000
