#include "devices/share/client_line_reader.hpp"

namespace gw::devices::share {

client_line_reader::client_line_reader(std::size_t max_line_bytes) : max_line_bytes_(max_line_bytes) {}

void client_line_reader::feed(std::string_view bytes, std::vector<client_line>& lines) {
    for (const char c : bytes) {
        const auto byte = static_cast<unsigned char>(c);
        if (halted_) {  // the CR after a HALT that went at once belongs to it
            halted_ = false;
            if (byte == '\r') continue;
        }
        if (byte == '\n') continue;
        // "\" at the start of a line is HALT at once, as the controller's fast path reads it: a program
        // may send it without a CR (mesoSPIM does) and wait for the answer.
        if (byte == '\\' && partial_.empty() && !spoiled_) {
            lines.push_back({client_line::kind::command, "\\"});
            halted_ = true;
            continue;
        }
        if (byte == '\r') {
            if (spoiled_)
                lines.push_back({client_line::kind::unreadable, {}});
            else if (partial_.find_first_not_of(' ') != std::string::npos)
                lines.push_back({client_line::kind::command, std::move(partial_)});
            partial_.clear();
            spoiled_ = false;
            continue;
        }
        if (spoiled_) continue;
        if (byte < 0x20 || byte > 0x7E || partial_.size() >= max_line_bytes_) {
            spoiled_ = true;
            partial_.clear();
            continue;
        }
        partial_.push_back(c);
    }
}

}  // namespace gw::devices::share
