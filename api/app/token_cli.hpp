#pragma once
// The "token" subcommand of asi-gateway: makes a bearer token and the config entry that holds only its
// hash (gateway/config/token_secret.hpp).
//
//   asi-gateway token new --name scheduler --role operator [--json]
//
// Prints the token once (it is not kept anywhere) and the auth.tokens entry with its token_sha256;
// with --json, one object {"name","role","token","token_sha256"} for scripts. Exit status 0, or 2 for
// a bad option.
//
//   gw::token_cli token(app);          // before CLI11_PARSE
//   CLI11_PARSE(app, argc, argv);
//   if (token.selected()) return token.run(std::cout, std::cerr);

#include <ostream>
#include <string>

namespace CLI {
class App;
}

namespace gw {

class token_cli {
  public:
    explicit token_cli(CLI::App& app);

    bool selected() const;
    int run(std::ostream& out, std::ostream& err) const;

  private:
    CLI::App* new_ = nullptr;
    std::string name_;
    std::string role_ = "viewer";
    bool json_ = false;
};

}  // namespace gw
