// The port probe's readers on arbitrary bytes: classify_version_answer() and parse_build_answer() never
// crash, and what they accept is consistent (a version only with a verdict that has one, printable
// reply lines only).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "devices/ms2000/identify_answer.hpp"
#include "devices/ms2000/reply_check.hpp"

namespace ms2000 = gw::devices::ms2000;

namespace {

void check(bool condition) {
    if (!condition) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    const auto a = ms2000::classify_version_answer(bytes);
    using kind = ms2000::version_answer::kind;
    check((a.what == kind::silent) == bytes.empty());
    if (a.what == kind::ms2000 || a.what == kind::tiger) {
        check(a.complete);
        check(!a.version.empty() && a.version[0] >= '0' && a.version[0] <= '9');
        check(ms2000::is_reply_text(a.line));
    } else {
        check(a.version.empty());
    }
    check(a.complete == ms2000::has_complete_line(bytes));
    if (const auto b = ms2000::parse_build_answer(bytes)) {
        check(!b->name.empty());
        check(ms2000::has_complete_line(bytes));
    }
    return 0;
}
