// parse_reply() on arbitrary bytes, in all five shapes, plus the helpers that read a reply.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "devices/ms2000/reply.hpp"

namespace ms2000 = gw::devices::ms2000;

namespace {

void check(bool condition) {
    if (!condition) std::abort();
}

void inspect(ms2000::reply_shape shape, std::string_view line) {
    const auto r = ms2000::parse_reply(shape, line);
    if (!r) return;
    check(r->raw == line);
    switch (r->what) {
        case ms2000::reply::kind::error:
            check(r->error_code <= 0);
            break;
        case ms2000::reply::kind::status:
            check(shape == ms2000::reply_shape::status);
            break;
        case ms2000::reply::kind::text:
            check(shape == ms2000::reply_shape::multiline && !r->lines.empty());
            for (const auto& l : r->lines)
                check(!l.empty() && l.find('\r') == std::string::npos);
            break;
        case ms2000::reply::kind::ack:
            break;
    }
    for (const auto& a : r->axes) {
        check(a.axis >= 'A' && a.axis <= 'Z');
        check(r->axis(a.axis) != nullptr);
    }
    for (std::size_t i = 0; i <= r->values.size(); ++i)
        (void)r->number(i);
    if (const auto v = ms2000::parse_version(*r)) check(!v->empty() && (*v)[0] >= '0' && (*v)[0] <= '9');
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view line(reinterpret_cast<const char*>(data), size);
    for (auto shape :
         {ms2000::reply_shape::standard, ms2000::reply_shape::status, ms2000::reply_shape::multiline,
          ms2000::reply_shape::two_phase, ms2000::reply_shape::status_bytes}) {
        inspect(shape, line);
    }
    (void)ms2000::parse_position_report(line);
    return 0;
}
