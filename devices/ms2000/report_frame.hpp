#pragma once
// Encoder report frames of the TTL_REPORT_INT module (seed 003), sent on the SERIAL OUT port.
// Binary frame, per axis: AID (0x18 X, 0x19 Y, 0x1A Z, 0x1B F, 0x1C T, 0x1D R, up to 0x1F), then the
// encoder count as a signed 32-bit little-endian integer; a final CR (0x0D) ends the frame.
// ASCII frame (our documented choice, ASI says "contact ASI"): "X=1234 Y=-5 Z=0\r\n".
// The decoder is a streaming, resynchronising state machine. It never trusts a length from the wire:
// a frame is at most max_axes axes, AIDs must strictly increase, and anything that breaks the
// pattern is skipped byte by byte and counted. Pure: no I/O, no clock.

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace gw::devices::ms2000 {

struct axis_count {
    char axis = 'X';
    std::int32_t count = 0;  // encoder counts

    bool operator==(const axis_count&) const = default;
};

struct report_frame {
    std::vector<axis_count> axes;  // wire order

    bool operator==(const report_frame&) const = default;
};

enum class report_format : std::uint8_t { binary, ascii };

inline constexpr std::uint8_t first_axis_id = 0x18;
inline constexpr std::uint8_t last_axis_id = 0x1F;
// 0x18 X, 0x19 Y, 0x1A Z, 0x1B F (seed 003), 0x1C T, 0x1D R (CMDs order), 0x1E A, 0x1F B (our choice,
// so that every AID has a letter); '?' outside 0x18..0x1F.
char axis_from_id(std::uint8_t id);
std::uint8_t axis_id(char axis);  // 'X' or 'x' -> 0x18; 0 if the letter has no id

// Axes are written in the given order (the decoder only accepts strictly increasing AIDs, i.e. the
// order X Y Z F T R A B); letters without an id are left out.
std::vector<std::uint8_t> encode_report(const report_frame& frame, report_format format);

class report_decoder {
  public:
    static constexpr std::size_t max_axes = last_axis_id - first_axis_id + 1;

    // expected_axes: the controller's motor axis count if known (frames of another size are
    // rejected); 0 accepts any count from 1 to max_axes.
    explicit report_decoder(report_format format = report_format::binary, std::size_t expected_axes = 0);

    // Appends every complete frame in `bytes` (which may cut frames anywhere) to `frames`.
    void feed(std::span<const std::uint8_t> bytes, std::vector<report_frame>& frames);

    std::uint64_t frames_decoded() const { return frames_decoded_; }
    std::uint64_t bytes_skipped() const { return bytes_skipped_; }
    // Bytes that went into decoded frames (ASCII: with their CR LF). Every byte fed is exactly one of
    // consumed, skipped or buffered.
    std::uint64_t bytes_consumed() const { return bytes_consumed_; }
    std::size_t buffered() const { return pending_.size(); }
    // Drops the buffered bytes (counted as skipped); the counters are kept.
    void reset();

    // Longest ASCII frame accepted: 8 x "X=-2147483648 " and the CR LF fit comfortably.
    static constexpr std::size_t max_ascii_line_bytes = 160;

  private:
    report_format format_;
    std::size_t expected_axes_;
    std::vector<std::uint8_t> pending_;  // bytes of the frame being assembled (bounded)
    std::uint64_t frames_decoded_ = 0;
    std::uint64_t bytes_skipped_ = 0;
    std::uint64_t bytes_consumed_ = 0;
    // ASCII only: what the LF right after a CR belongs to.
    enum class after_cr : std::uint8_t { nothing, frame, garbage } after_cr_ = after_cr::nothing;
    bool discarding_ = false;  // ASCII only: inside an overlong line, skipping up to its end

    void feed_binary(std::span<const std::uint8_t> bytes, std::vector<report_frame>& frames);
    void feed_ascii(std::span<const std::uint8_t> bytes, std::vector<report_frame>& frames);
    bool accept(const report_frame& frame) const;
};

}  // namespace gw::devices::ms2000
