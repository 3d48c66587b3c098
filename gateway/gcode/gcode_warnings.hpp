#pragma once
// Warnings of one translation, kept in bounded memory: one entry per kind, with the first place it
// happened and how often. "line 12: X1000 has no decimal point ... (and 340 more lines)".

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace gw::gcode {

enum class warning_kind : std::uint8_t {
    no_decimal_point,
    semicolon_words,
    block_delete,
    n_zero,
    r_and_ijk,
    zero_degree_arc,
    feed_clamped,
    analog_clamped,
    units_switched,
    no_closing_percent,
    ttl_on_at_end,
    text_after_end,
    count_  // not a kind
};

class gcode_warnings {
  public:
    // Records one occurrence; the message of the first occurrence is kept.
    void add(warning_kind kind, int line, std::string message);
    std::size_t count(warning_kind kind) const { return entries_[static_cast<std::size_t>(kind)].count; }
    bool empty() const;
    // One text per kind that occurred, in kind order.
    std::vector<std::string> texts() const;

  private:
    struct entry {
        std::size_t count = 0;
        int line = 0;
        std::string message;
    };
    entry entries_[static_cast<std::size_t>(warning_kind::count_)];
};

}  // namespace gw::gcode
