#pragma once
// Splits what a shared port's client sends into command lines, as the controller's own input does: a
// line ends with CR; LF is ignored (clients send CR LF, and a lone LF is what some send between
// commands); an empty line is no command; "\" at the start of a line is a HALT at once, with or
// without its CR (the controller's fast path). Pure: no I/O, no clock.
//
// A line that holds a byte outside printable ASCII, or grows beyond max_line_bytes, is reported as
// `unreadable` when its CR arrives (its bytes are dropped as they come, so memory stays bounded) and
// never becomes a command.

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace gw::devices::share {

struct client_line {
    enum class kind : bool { command, unreadable };
    kind what = kind::command;
    std::string text;  // the line without its CR (empty when unreadable)
};

class client_line_reader {
  public:
    explicit client_line_reader(std::size_t max_line_bytes);

    // Appends the lines that `bytes` completes to `lines`.
    void feed(std::string_view bytes, std::vector<client_line>& lines);

    std::size_t pending_bytes() const { return partial_.size(); }

  private:
    std::size_t max_line_bytes_;
    std::string partial_;
    bool spoiled_ = false;  // the line being read holds a byte that cannot be sent, or is too long
    bool halted_ = false;   // a HALT was just taken without waiting for its CR
};

}  // namespace gw::devices::share
