#pragma once
// What `--check-config` checks beyond the config's syntax: the files it names. The TLS files of MQTT
// (CA, certificate, key) and HTTP (certificate, key) must exist, be readable regular files and look like PEM
// (an error each); a serial port that does not exist now is a warning (an adapter may be plugged in later),
// and so is one this user may not open. Reads the file system only.

#include <string>
#include <vector>

#include "gateway/config/config.hpp"

namespace gw {

struct config_finding {
    bool error = false;   // false: a warning
    std::string message;  // "mqtt.tls.ca_file: /etc/ca.pem: No such file or directory"
};

std::vector<config_finding> check_config_files(const gateway_config& config);

}  // namespace gw
