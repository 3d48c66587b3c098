#include "gateway/config/config_files_check.hpp"

#include <cerrno>
#include <fstream>
#include <sys/stat.h>
#include <system_error>
#include <unistd.h>

namespace gw {

namespace {

std::string errno_text(int err) {
    return std::generic_category().message(err);
}

// An error message, or empty when `path` is a readable PEM file.
std::string pem_problem(const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return path + ": " + errno_text(errno);
    if (!S_ISREG(st.st_mode)) return path + ": not a regular file";
    std::ifstream in(path, std::ios::binary);
    if (!in) return path + ": cannot be read (" + errno_text(errno) + ")";
    std::string head(4096, '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<std::size_t>(in.gcount()));
    if (head.find("-----BEGIN ") == std::string::npos)
        return path + ": not a PEM file (no \"-----BEGIN\" line)";
    return {};
}

void check_port(std::vector<config_finding>& out, const std::string& where, const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) {
        out.push_back({false, where + ": " + path + " does not exist now (" + errno_text(errno) +
                                  "); fine if the adapter is plugged in later ('asi-gateway ports' lists "
                                  "the ports there are; prefer /dev/serial/by-id/ paths)"});
        return;
    }
    if (!S_ISCHR(st.st_mode)) {
        out.push_back({false, where + ": " + path + " is not a character device (a serial port)"});
        return;
    }
    if (::access(path.c_str(), R_OK | W_OK) != 0)
        out.push_back({false, where + ": " + path + ": this user may not open it (" + errno_text(errno) +
                                  "); the gateway's user needs the dialout group"});
}

}  // namespace

std::vector<config_finding> check_config_files(const gateway_config& config) {
    std::vector<config_finding> out;
    const auto& tls = config.mqtt.tls;
    for (const auto& [key, path] :
         {std::pair<const char*, const std::string&>{"mqtt.tls.ca_file", tls.ca_file},
          {"mqtt.tls.cert_file", tls.cert_file},
          {"mqtt.tls.key_file", tls.key_file},
          {"http.tls.cert_file", config.http.tls.cert_file},
          {"http.tls.key_file", config.http.tls.key_file}}) {
        if (path.empty()) continue;
        if (auto problem = pem_problem(path); !problem.empty())
            out.push_back({true, std::string(key) + ": " + problem});
    }
    for (std::size_t i = 0; i < config.controllers.size(); ++i) {
        const auto& c = config.controllers[i];
        const auto where = "controllers[" + std::to_string(i) + "]";
        check_port(out, where + ".port", c.port);
        if (!c.report_port.empty()) check_port(out, where + ".report_port", c.report_port);
    }
    return out;
}

}  // namespace gw
