#pragma once
// Splits the controller's byte stream into reply lines. Pure: no I/O, no clock.
// A reply ends with CR LF; the lines of a multi-line reply (BUILD X, INFO) are separated by CR alone
// and stay inside one framed line ("STD_XYZ\rMotor Axes: X Y Z\r...\r\n" -> one line with CRs).
// A stray LF (no CR before it) is dropped. Used on the driver's strand only.
// RDSBYTE's answer (":" then one raw status byte per axis, CR LF) may hold CR and LF bytes of its own:
// after expect_status_bytes(n), the next line that starts with ":" takes n bytes after the colon whatever
// they are, then its CR LF; ":N-<digits>" CR LF still ends it as an error reply. If the CR LF is not where
// it should be, those bytes are framed as any others (what comes of them fits no reply, and the driver
// resynchronises).

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <boost/system/error_code.hpp>

namespace gw::devices::ms2000 {

class line_framer {
  public:
    static constexpr std::size_t default_max_line_bytes = 8192;  // INFO is over 1023 characters

    explicit line_framer(std::size_t max_line_bytes = default_max_line_bytes);

    // Appends complete lines (without the final CR LF) to `lines`. Returns error::line_too_long when a
    // line outgrew the bound; its bytes are discarded up to the next CR LF and framing goes on.
    boost::system::error_code feed(std::string_view bytes, std::vector<std::string>& lines);

    // Bytes of the line not yet ended (SAVESET's ":" before the flash write completes).
    std::string_view partial() const { return partial_; }

    // Drops the partial line (stale input before a new command); counted in discarded_bytes(). Ends an
    // expect_status_bytes() too.
    void reset();

    // The next line that starts with ":" is RDSBYTE's answer with `count` raw bytes (count > 0).
    void expect_status_bytes(std::size_t count) { status_bytes_ = count; }

    std::uint64_t discarded_bytes() const { return discarded_bytes_; }

  private:
    std::size_t max_line_bytes_;
    std::string partial_;
    bool overflowing_ = false;
    bool overflow_cr_ = false;  // while overflowing: the last discarded byte was CR
    std::uint64_t discarded_bytes_ = 0;
    std::size_t status_bytes_ = 0;  // expect_status_bytes(): raw bytes the next ":" line carries

    // In an RDSBYTE answer, what `partial_` is with the byte just added; clears status_bytes_ when it
    // is the whole answer or cannot be one.
    enum class status_step : std::uint8_t { more, answer, not_answer };
    status_step take_status_byte();
};

}  // namespace gw::devices::ms2000
