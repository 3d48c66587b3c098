#include "devices/ms2000/line_framer.hpp"

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

void line_framer::reset() {
    discarded_bytes_ += partial_.size();
    partial_.clear();
    overflowing_ = false;
    overflow_cr_ = false;
}

}  // namespace gw::devices::ms2000
