#include "devices/ms2000/reply_check.hpp"

#include <algorithm>

#include "devices/ms2000/error.hpp"

namespace gw::devices::ms2000 {

namespace {

bool all_numbers(const reply& r) {
    for (std::size_t i = 0; i < r.values.size(); ++i) {
        if (!r.number(i)) return false;
    }
    return true;
}

// ":A NB" for "RS X? Y?": one letter per axis, no spaces between them.
bool adjacent_letters(const std::string& token, std::size_t count) {
    return token.size() == count && std::all_of(token.begin(), token.end(), [](char c) {
               return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z');
           });
}

bool fits_axis_values(const reply_form& form, const reply& r) {
    if (r.what != reply::kind::ack) return false;
    const bool named = !r.axes.empty() && std::all_of(form.axes.begin(), form.axes.end(),
                                                      [&](char axis) { return r.axis(axis) != nullptr; });
    if (named) return true;
    if (!form.positional || !r.axes.empty() || r.values.empty()) return false;
    if (r.values.size() == form.axes.size()) return true;
    return r.values.size() == 1 && adjacent_letters(r.values.front(), form.axes.size());
}

}  // namespace

bool reply_fits(const reply_form& form, const reply& r) {
    if (r.what == reply::kind::error) return true;
    switch (form.what) {
        case reply_form::kind::any:
            return true;
        case reply_form::kind::bare_ack:
            return r.what == reply::kind::ack && r.values.empty() && r.axes.empty();
        case reply_form::kind::numbers:
            return r.what == reply::kind::ack && r.axes.empty() && r.values.size() == form.axes.size() &&
                   all_numbers(r);
        case reply_form::kind::axis_values:
            return fits_axis_values(form, r);
        case reply_form::kind::version:
            return parse_version(r).has_value();
        case reply_form::kind::build_text:
            return r.what == reply::kind::text;
        case reply_form::kind::status_bytes:
            return r.what == reply::kind::ack && r.raw.size() == 1 + form.axes.size();
        case reply_form::kind::integers:
            return r.what == reply::kind::ack && r.axes.empty() &&
                   std::all_of(r.values.begin(), r.values.end(), [](const std::string& v) {
                       return !v.empty() &&
                              std::all_of(v.begin(), v.end(), [](char c) { return c >= '0' && c <= '9'; });
                   });
    }
    return false;
}

boost::system::result<reply> accept_reply(const command& cmd, std::string_view line) {
    // RDSBYTE's answer is the one made of raw bytes; its length is checked instead (reply_fits).
    const bool binary = cmd.expect == reply_shape::status_bytes;
    if (!binary && !is_reply_text(line)) return make_error_code(error::unrecognized_reply);
    auto parsed = parse_reply(cmd.expect, line);
    if (!parsed) return parsed.error();
    if (!reply_fits(cmd.form, *parsed)) return make_error_code(error::unrecognized_reply);
    return parsed;
}

bool is_reply_text(std::string_view line) {
    return std::all_of(line.begin(), line.end(), [](char c) {
        const auto byte = static_cast<unsigned char>(c);
        return (byte >= 0x20 && byte <= 0x7E) || c == '\r';
    });
}

}  // namespace gw::devices::ms2000
