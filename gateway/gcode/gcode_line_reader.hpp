#pragma once
// Reads a program line by line from a stream in bounded memory. A line ends at LF, CR or CR LF (all
// three count as one line end). A line longer than the limit is an error, never truncated.

#include <cstddef>
#include <istream>
#include <optional>
#include <string>
#include <string_view>

#include "gateway/gcode/gcode_error.hpp"

namespace gw::gcode {

class gcode_line_reader {
  public:
    gcode_line_reader(std::istream& in, std::size_t max_chars) : in_(in), max_chars_(max_chars) {}

    // The next line (without its end), or nullopt at the end of the stream or on error (error() set).
    // The view is valid until the next call.
    std::optional<std::string_view> next();
    int line() const { return line_; }  // 1-based number of the last line returned
    const std::optional<gcode_error>& error() const { return error_; }

  private:
    std::istream& in_;
    std::size_t max_chars_;
    std::string buffer_;
    int line_ = 0;
    std::optional<gcode_error> error_;
};

}  // namespace gw::gcode
