#include "gateway/config/tokens_file.hpp"

#include <cerrno>
#include <fstream>
#include <sstream>
#include <sys/stat.h>
#include <system_error>

#include <nlohmann/json.hpp>

namespace gw {

namespace {

constexpr std::size_t max_tokens_file_bytes = std::size_t{1} << 20;

bool holds_plain_token(const nlohmann::json& j) {
    if (j.is_array()) {
        for (const auto& item : j)
            if (holds_plain_token(item)) return true;
        return false;
    }
    return j.is_object() && j.contains("token");
}

}  // namespace

bool holds_plain_tokens(std::string_view json_text) {
    const auto j = nlohmann::json::parse(json_text, nullptr, false);
    return !j.is_discarded() && holds_plain_token(j);
}

boost::system::result<std::string, tokens_file_problem> read_tokens_file(const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0)
        return tokens_file_problem{path + ": " + std::generic_category().message(errno)};
    if (!S_ISREG(st.st_mode)) return tokens_file_problem{path + ": not a regular file"};
    if (static_cast<std::size_t>(st.st_size) > max_tokens_file_bytes)
        return tokens_file_problem{path + ": larger than 1 MiB"};
    std::ifstream in(path, std::ios::binary);
    if (!in)
        return tokens_file_problem{path + ": cannot be read (" + std::generic_category().message(errno) +
                                   ")"};
    std::ostringstream text;
    text << in.rdbuf();
    if ((st.st_mode & S_IROTH) != 0 && holds_plain_tokens(text.str()))
        return tokens_file_problem{path + ": holds plain tokens and every user may read it: chmod o-r " +
                                   path + " (or keep token_sha256 hashes there)"};
    return {boost::system::in_place_value, text.str()};
}

}  // namespace gw
