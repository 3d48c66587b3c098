#pragma once
// The dashboard's files (api/dashboard/*.html, *.js, *.css, *.svg), embedded at build time by
// api/embed_dashboard.cmake, served by api/static_assets.hpp.

#include <span>
#include <string_view>

namespace gw::api {

struct embedded_file {
    std::string_view name;    // "app.js": the file name inside api/dashboard/
    std::string_view sha256;  // hex SHA-256 of `data`, computed at build time
    std::string_view data;
};

// Sorted by name.
std::span<const embedded_file> dashboard_files();

}  // namespace gw::api
