#include "api/http/tls_server_context.hpp"

#include <cerrno>
#include <cstdio>
#include <openssl/err.h>
#include <openssl/ssl.h>
#include <stdexcept>
#include <system_error>

namespace gw::api {

namespace ssl = boost::asio::ssl;

namespace {

// TLS 1.2 suites with forward secrecy and authenticated encryption (TLS 1.3's are all of that).
constexpr const char* tls12_ciphers =
    "ECDHE-ECDSA-AES128-GCM-SHA256:ECDHE-RSA-AES128-GCM-SHA256:ECDHE-ECDSA-AES256-GCM-SHA384:"
    "ECDHE-RSA-AES256-GCM-SHA384:ECDHE-ECDSA-CHACHA20-POLY1305:ECDHE-RSA-CHACHA20-POLY1305";

// OpenSSL's reason for the last failure, or the errno of a file that could not be opened.
std::string openssl_reason(const std::string& path) {
    if (FILE* f = std::fopen(path.c_str(), "r")) {
        std::fclose(f);
    } else {
        const int error = errno;
        ERR_clear_error();
        return std::generic_category().message(error);
    }
    const unsigned long code = ERR_peek_error();  // the first: the cause, not the layers above it
    ERR_clear_error();
    if (code == 0) return "not usable";
    const char* reason = ERR_reason_error_string(code);
    return reason ? reason : "not usable";
}

}  // namespace

boost::system::result<std::shared_ptr<ssl::context>, tls_problem> make_tls_server_context(
    const http_tls_config& files) {
    auto ctx = std::make_shared<ssl::context>(ssl::context::tls_server);
    SSL_CTX* native = ctx->native_handle();
    SSL_CTX_set_min_proto_version(native, TLS1_2_VERSION);
    SSL_CTX_set_options(native, SSL_OP_NO_COMPRESSION | SSL_OP_NO_RENEGOTIATION |
                                    SSL_OP_CIPHER_SERVER_PREFERENCE | SSL_OP_SINGLE_DH_USE);
    SSL_CTX_set_cipher_list(native, tls12_ciphers);
    // An encrypted key fails at once: OpenSSL's default would ask for a passphrase on the terminal.
    SSL_CTX_set_default_passwd_cb(native, [](char*, int, int, void*) { return 0; });
    ERR_clear_error();
    if (SSL_CTX_use_certificate_chain_file(native, files.cert_file.c_str()) != 1)
        return tls_problem{"http.tls.cert_file: " + files.cert_file + ": " + openssl_reason(files.cert_file)};
    if (SSL_CTX_use_PrivateKey_file(native, files.key_file.c_str(), SSL_FILETYPE_PEM) != 1)
        return tls_problem{"http.tls.key_file: " + files.key_file + ": " + openssl_reason(files.key_file)};
    if (SSL_CTX_check_private_key(native) != 1) {
        ERR_clear_error();
        return tls_problem{"http.tls.key_file: " + files.key_file + ": does not match the certificate in " +
                           files.cert_file};
    }
    return ctx;
}

tls_server_context::tls_server_context(http_tls_config files) : files_(std::move(files)) {
    auto ctx = make_tls_server_context(files_);
    if (!ctx) throw std::runtime_error(ctx.error().message);
    current_ = std::move(*ctx);
}

std::shared_ptr<ssl::context> tls_server_context::current() const {
    std::lock_guard lock(mutex_);
    return current_;
}

std::string tls_server_context::reload() {
    auto ctx = make_tls_server_context(files_);
    if (!ctx) return ctx.error().message;
    std::lock_guard lock(mutex_);
    current_ = std::move(*ctx);
    return {};
}

}  // namespace gw::api
