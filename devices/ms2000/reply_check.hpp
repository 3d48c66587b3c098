#pragma once
// Whether a parsed reply can be the answer to the command that was sent. Pure: no I/O.
// parse_reply() checks the shape of a line; reply_fits() checks its content against the command's
// reply_form, so that a late reply of another command is never taken for this one's answer.

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/reply.hpp"

namespace gw::devices::ms2000 {

// True when `r` can answer a command of `form`. An error reply (":N-<code>") fits every form.
bool reply_fits(const reply_form& form, const reply& r);

// The whole test a received line must pass to be the answer to `cmd`: printable ASCII (but for RDSBYTE's
// raw bytes), the shape cmd.expect, the content cmd.form. error::unrecognized_reply otherwise (the link is
// then out of step).
boost::system::result<reply> accept_reply(const command& cmd, std::string_view line);

// True when every byte of a received line is printable ASCII (0x20..0x7E) or a CR between the lines
// of a multi-line reply. MS-2000 replies are ASCII: a line with any other byte is noise.
bool is_reply_text(std::string_view line);

}  // namespace gw::devices::ms2000
