// line_framer on arbitrary bytes cut at arbitrary points.
// Input: byte 0 = line bound (0 -> default, else 1..255), byte 1 = seed of the split points and, its
// value modulo 5, the raw bytes of an RDSBYTE answer expected (0: none), then bytes.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "devices/ms2000/line_framer.hpp"

namespace ms2000 = gw::devices::ms2000;

namespace {

void check(bool condition) {
    if (!condition) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 2) return 0;
    const std::size_t bound = data[0] == 0 ? ms2000::line_framer::default_max_line_bytes : data[0];
    std::uint32_t seed = data[1] * 2654435761u + 7;
    const std::string_view input(reinterpret_cast<const char*>(data + 2), size - 2);

    const std::size_t status_bytes = data[1] % 5;

    ms2000::line_framer whole(bound);
    if (status_bytes > 0) whole.expect_status_bytes(status_bytes);
    std::vector<std::string> whole_lines;
    const bool whole_error = whole.feed(input, whole_lines).failed();

    ms2000::line_framer pieces(bound);
    if (status_bytes > 0) pieces.expect_status_bytes(status_bytes);
    std::vector<std::string> piece_lines;
    bool piece_error = false;
    std::size_t pos = 0;
    while (pos < input.size()) {
        seed = seed * 1103515245u + 12345u;
        const std::size_t n = std::min<std::size_t>(input.size() - pos, (seed >> 16) % 17);
        piece_error |= pieces.feed(input.substr(pos, n), piece_lines).failed();
        pos += n;
    }
    check(piece_lines == whole_lines);
    check(piece_error == whole_error);
    check(pieces.partial() == whole.partial());
    check(pieces.discarded_bytes() == whole.discarded_bytes());

    // Every byte is in a line (plus its CR LF), discarded, or still partial. Only the RDSBYTE answer, the
    // first line that starts with ':', may hold LF bytes or outgrow the bound: then it has its size.
    std::size_t accounted = whole.discarded_bytes() + whole.partial().size();
    bool status_line_seen = false;
    for (const auto& line : whole_lines) {
        const bool may_be_status = status_bytes > 0 && !status_line_seen && line.starts_with(':');
        status_line_seen |= may_be_status;
        if (!may_be_status || line.size() != 1 + status_bytes) {
            check(line.size() <= bound || (may_be_status && line.starts_with(":N-")));
            check(line.find('\n') == std::string::npos);
        }
        accounted += line.size() + 2;
    }
    check(accounted == input.size());
    // An RDSBYTE answer still coming may be longer than the bound: at most 1 + status_bytes + 1 bytes.
    check(whole.partial().size() <= std::max(bound + 1, status_bytes + 2));
    return 0;
}
