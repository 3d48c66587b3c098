// report_decoder on arbitrary bytes cut at arbitrary points.
// Input: byte 0 = format (bit 0) and expected axis count ((byte >> 1) % 9), byte 1 = seed of the
// split points, then the stream.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "devices/ms2000/report_frame.hpp"

namespace ms2000 = gw::devices::ms2000;

namespace {

void check(bool condition) {
    if (!condition) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 2) return 0;
    const auto format = (data[0] & 1) ? ms2000::report_format::ascii : ms2000::report_format::binary;
    const std::size_t expected = (data[0] >> 1) % (ms2000::report_decoder::max_axes + 1);
    std::uint32_t seed = data[1] * 2654435761u + 1;
    const std::span<const std::uint8_t> stream(data + 2, size - 2);

    // The same stream in one feed and in random pieces must give the same frames and counters.
    ms2000::report_decoder whole(format, expected);
    std::vector<ms2000::report_frame> whole_frames;
    whole.feed(stream, whole_frames);

    ms2000::report_decoder pieces(format, expected);
    std::vector<ms2000::report_frame> piece_frames;
    std::size_t pos = 0;
    while (pos < stream.size()) {
        seed = seed * 1103515245u + 12345u;
        const std::size_t n = std::min<std::size_t>(stream.size() - pos, (seed >> 16) % 23);
        pieces.feed(stream.subspan(pos, n), piece_frames);
        pos += n;
    }
    check(piece_frames == whole_frames);
    for (const auto* d : {&whole, &pieces}) {
        check(d->bytes_skipped() + d->bytes_consumed() + d->buffered() == stream.size());
        check(d->frames_decoded() == whole_frames.size());
    }
    check(whole.bytes_skipped() == pieces.bytes_skipped());

    for (const auto& frame : whole_frames) {
        check(!frame.axes.empty() && frame.axes.size() <= ms2000::report_decoder::max_axes);
        check(expected == 0 || frame.axes.size() == expected);
        for (std::size_t i = 1; i < frame.axes.size(); ++i) {
            check(ms2000::axis_id(frame.axes[i - 1].axis) < ms2000::axis_id(frame.axes[i].axis));
        }
        // Every decoded frame re-encodes to bytes that decode to the same frame, with nothing skipped.
        const auto bytes = ms2000::encode_report(frame, format);
        ms2000::report_decoder again(format, expected);
        std::vector<ms2000::report_frame> out;
        again.feed(bytes, out);
        check(out.size() == 1 && out[0] == frame);
        check(again.bytes_skipped() == 0 && again.buffered() == 0);
    }
    return 0;
}
