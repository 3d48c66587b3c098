#include "devices/ms2000/line_framer.hpp"

#include <algorithm>

#include "devices/ms2000/error.hpp"

namespace gw::devices::ms2000 {

line_framer::line_framer(std::size_t max_line_bytes)
    : max_line_bytes_(max_line_bytes == 0 ? 1 : max_line_bytes) {}

boost::system::error_code line_framer::feed(std::string_view bytes, std::vector<std::string>& lines) {
    boost::system::error_code result;
    for (const char c : bytes) {
        if (overflowing_) {
            // Discard the rest of the overlong line, up to and including its CR LF.
            ++discarded_bytes_;
            if (c == '\n' && overflow_cr_) overflowing_ = false;
            overflow_cr_ = c == '\r';
            continue;
        }
        // An RDSBYTE answer: a line that starts with ':' while status bytes are expected (a position
        // report "T: .." that came first is framed as usual).
        if (status_bytes_ > 0 && (partial_.empty() ? c == ':' : partial_.front() == ':')) {
            partial_.push_back(c);
            const auto step = take_status_byte();
            if (step == status_step::more) continue;
            std::string line = std::move(partial_);
            partial_.clear();
            if (step == status_step::answer) {
                line.resize(line.size() - 2);  // the CR LF
                lines.push_back(std::move(line));
            } else if (auto framing = feed(line, lines); framing && !result) {
                result = framing;  // not the answer: its bytes are framed as any others
            }
            continue;
        }
        if (c == '\n') {
            if (!partial_.empty() && partial_.back() == '\r') {
                partial_.pop_back();
                lines.push_back(std::move(partial_));
                partial_.clear();
            } else {
                ++discarded_bytes_;  // a stray LF (no CR before it) ends nothing
            }
            continue;
        }
        partial_.push_back(c);
        // The line may hold max_line_bytes plus the CR that is waiting for its LF.
        const bool pending_cr = partial_.back() == '\r';
        if (partial_.size() > max_line_bytes_ + (pending_cr ? 1 : 0)) {
            discarded_bytes_ += partial_.size();
            partial_.clear();
            overflowing_ = true;
            overflow_cr_ = pending_cr;
            if (!result) result = make_error_code(error::line_too_long);
        }
    }
    return result;
}

line_framer::status_step line_framer::take_status_byte() {
    const std::string_view line = partial_;
    const bool ends_line = line.ends_with("\r\n");
    // ":N-12" CR LF: the controller refused the command.
    if (ends_line && line.size() >= 6 && line.starts_with(":N-") &&
        std::all_of(line.begin() + 3, line.end() - 2, [](char c) { return c >= '0' && c <= '9'; })) {
        status_bytes_ = 0;
        return status_step::answer;
    }
    const std::size_t whole = 1 + status_bytes_ + 2;
    if (line.size() < whole) return status_step::more;
    status_bytes_ = 0;
    return ends_line ? status_step::answer : status_step::not_answer;
}

void line_framer::reset() {
    discarded_bytes_ += partial_.size();
    partial_.clear();
    overflowing_ = false;
    overflow_cr_ = false;
    status_bytes_ = 0;
}

}  // namespace gw::devices::ms2000
