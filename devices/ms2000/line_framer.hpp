#pragma once
// Splits the controller's byte stream into reply lines. Pure: no I/O, no clock.
// A reply ends with CR LF; the lines of a multi-line reply (BUILD X, INFO) are separated by CR alone
// and stay inside one framed line ("STD_XYZ\rMotor Axes: X Y Z\r...\r\n" -> one line with CRs).
// A stray LF (no CR before it) is dropped. Used on the driver's strand only.

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

    // Drops the partial line (stale input before a new command); counted in discarded_bytes().
    void reset();

    std::uint64_t discarded_bytes() const { return discarded_bytes_; }

  private:
    std::size_t max_line_bytes_;
    std::string partial_;
    bool overflowing_ = false;
    bool overflow_cr_ = false;  // while overflowing: the last discarded byte was CR
    std::uint64_t discarded_bytes_ = 0;
};

}  // namespace gw::devices::ms2000
