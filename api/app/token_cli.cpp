#include "api/app/token_cli.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "gateway/common/json_text.hpp"
#include "gateway/config/token_secret.hpp"

namespace gw {

token_cli::token_cli(CLI::App& app) {
    auto* token = app.add_subcommand("token", "Bearer tokens for the config's auth.tokens");
    token->require_subcommand(1);
    new_ = token->add_subcommand("new", "Make a token: printed once, with the config entry of its hash");
    new_->add_option("--name", name_, "The token's name, as logs and whoami show it")->required();
    new_->add_option("--role", role_, "viewer, operator or admin")
        ->check(CLI::IsMember({"viewer", "operator", "admin"}));
    new_->add_flag("--json", json_, "Print {\"name\",\"role\",\"token\",\"token_sha256\"} for scripts");
}

bool token_cli::selected() const {
    return new_ && new_->parsed();
}

int token_cli::run(std::ostream& out, std::ostream& err) const {
    if (name_.empty()) {
        err << "asi-gateway token new: --name must not be empty\n";
        return 2;
    }
    const auto token = new_token();
    const auto digest = to_hex(hash_token(token));
    if (json_) {
        out << to_json_text(nlohmann::json{
                   {"name", name_}, {"role", role_}, {"token", token}, {"token_sha256", digest}})
            << '\n';
        return 0;
    }
    // Keys in the order of the config's documentation, not nlohmann's sorted order.
    out << "token for " << to_json_text(nlohmann::json(name_)) << " (" << role_
        << "), shown only now: give it to the client\n  " << token << '\n'
        << "the config's auth.tokens entry (the gateway keeps only the hash):\n"
        << "  {\"name\": " << to_json_text(nlohmann::json(name_)) << ", \"role\": \"" << role_
        << "\", \"token_sha256\": \"" << digest << "\"}\n";
    return 0;
}

}  // namespace gw
