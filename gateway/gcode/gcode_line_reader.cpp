#include "gateway/gcode/gcode_line_reader.hpp"

#include <string>

namespace gw::gcode {

std::optional<std::string_view> gcode_line_reader::next() {
    if (error_) return std::nullopt;
    std::streambuf* sb = in_.rdbuf();
    if (sb == nullptr) return std::nullopt;
    using traits = std::streambuf::traits_type;
    buffer_.clear();
    int c = sb->sbumpc();
    if (c == traits::eof()) return std::nullopt;
    ++line_;
    while (c != traits::eof()) {
        if (c == '\n') break;
        if (c == '\r') {
            if (sb->sgetc() == '\n') sb->sbumpc();
            break;
        }
        if (buffer_.size() >= max_chars_) {
            error_ = gcode_error{line_, static_cast<int>(max_chars_) + 1,
                                 "line longer than " + std::to_string(max_chars_) + " characters"};
            return std::nullopt;
        }
        buffer_.push_back(traits::to_char_type(c));
        c = sb->sbumpc();
    }
    return std::string_view(buffer_);
}

}  // namespace gw::gcode
