// The command builders on arbitrary input: nothing but printable ASCII and the final CR may reach the
// wire. Input: the whole of it as a raw command line; then, read as a little program, one
// make_command() call and one format_number() call.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "devices/ms2000/command.hpp"

namespace ms2000 = gw::devices::ms2000;

namespace {

void check(bool condition) {
    if (!condition) std::abort();
}

void check_wire(const ms2000::command& c) {
    check(!c.wire.empty() && c.wire.back() == '\r');
    for (std::size_t i = 0; i + 1 < c.wire.size(); ++i) {
        const auto byte = static_cast<unsigned char>(c.wire[i]);
        check(byte >= 0x20 && byte <= 0x7E);
    }
    check(!c.verb.empty() && c.wire.starts_with(c.verb));
    for (char v : c.verb)
        check(!(v >= 'a' && v <= 'z'));
    check(c.long_reply ==
          (c.expect == ms2000::reply_shape::multiline || c.expect == ms2000::reply_shape::two_phase));
}

double read_double(const std::uint8_t* p) {
    double value = 0;
    std::memcpy(&value, p, sizeof value);
    return value;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view line(reinterpret_cast<const char*>(data), size);
    if (const auto c = ms2000::raw_command(line)) {
        check_wire(*c);
        check(c->wire.size() <= ms2000::max_raw_command_bytes + 1);
    }

    // make_command: verb length, verb, then 10-byte arguments (axis, kind, decimals, double).
    if (size < 1) return 0;
    const std::size_t verb_size = std::min<std::size_t>(data[0] % 16, size - 1);
    const std::string_view verb(reinterpret_cast<const char*>(data + 1), verb_size);
    std::vector<ms2000::argument> args;
    for (std::size_t pos = 1 + verb_size; pos + 11 <= size; pos += 11) {
        ms2000::argument a;
        a.axis = static_cast<char>(data[pos]);
        a.kind = static_cast<ms2000::argument::op>(data[pos + 1] % 6);
        a.decimals = static_cast<std::int8_t>(data[pos + 2]);
        a.value = read_double(data + pos + 3);
        args.push_back(a);
    }
    if (const auto c = ms2000::make_command(verb, args, static_cast<ms2000::reply_shape>(data[0] % 4))) {
        check_wire(*c);
    }

    // format_number: fixed notation that reads back to the value it was given, rounded.
    if (size >= 9) {
        const double value = read_double(data + size - 8);
        const int decimals = data[size - 9] % 12;
        const std::string text = ms2000::format_number(value, decimals);
        if (!std::isfinite(value)) {
            check(text.empty());
        } else {
            check(!text.empty() && text != "-0");
            check(text.find_first_not_of("-0123456789.") == std::string::npos);
            check(text.back() != '.' && (text.find('.') == std::string::npos || text.back() != '0'));
            if (std::fabs(value) < 1e12) {
                double back = 0;
                const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), back);
                check(ec == std::errc{} && ptr == text.data() + text.size());
                const int used = std::min(decimals, 9);
                check(std::fabs(back - value) <=
                      0.5 * std::pow(10.0, -used) * (1 + 1e-9) + std::fabs(value) * 1e-15);
            }
        }
    }
    return 0;
}
