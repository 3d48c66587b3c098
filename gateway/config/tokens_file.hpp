#pragma once
// auth.tokens_file: the tokens kept outside the main config, in a file only the gateway may read
// (a systemd credential, a Docker secret, a 0640 file). It holds a JSON array of entries shaped like
// auth.tokens ([{"name", "role", "token_sha256"}]); they are added to auth.tokens.
//
//   - its path is resolved like every secret file's (gateway/config/secret_file_path.hpp);
//   - a file that holds plain "token" values and that every user may read is refused: whoever reads
//     it could drive the stages (hashes, token_sha256, may be read: they cannot be used as tokens).

#include <string>
#include <string_view>

#include <boost/system/result.hpp>

namespace gw {

struct tokens_file_problem {
    std::string message;
};

// The file's text, or why it cannot be used (unreadable, too large, plain tokens readable by all).
boost::system::result<std::string, tokens_file_problem> read_tokens_file(const std::string& path);

// True when the JSON text has a "token" key with a value (a plain token, not a hash). Textual: the
// permission check runs before the entries are read.
bool holds_plain_tokens(std::string_view json_text);

}  // namespace gw
