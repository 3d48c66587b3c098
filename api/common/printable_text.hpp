#pragma once
// The one rule for client text the API accepts or repeats. Two kinds, by what the text is for:
// - a word (ids, keys, names: Idempotency-Key, Lease-Id, topic parts): printable ASCII without spaces,
//   0x21..0x7e, so it is the same value in a header, a query, a log line and a JSON field;
// - a label a person writes (a lease holder, a WebSocket request id): printable ASCII, spaces allowed.
// Anything else (control characters, bytes above 0x7e) is refused, and never repeated in a message.

#include <string>
#include <string_view>

namespace gw::api {

bool is_printable_word(std::string_view s);
bool is_printable_label(std::string_view s);

// For error messages and problem fields: the client's text itself when it is a short printable word
// (64 characters at most), else "..." (a kilobyte of name, a control character or a blank that would
// be hard to see between quotes stays out).
std::string shown_in_message(std::string_view s);

}  // namespace gw::api
