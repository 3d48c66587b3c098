#include "api/app/gcode_cli.hpp"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <unistd.h>

#include <CLI/CLI.hpp>

#include "gateway/gcode/gcode_options.hpp"
#include "gateway/gcode/gcode_plan_json.hpp"
#include "gateway/gcode/gcode_plan_summary_json.hpp"
#include "gateway/gcode/gcode_preview_svg.hpp"

namespace gw {

namespace {

// Copies stdin into an unlinked temporary file and opens it: a seekable stream, so the program can be
// checked before anything is printed. The disk, not the memory, holds a big program.
bool spool_stdin(std::ifstream& in, std::ostream& err) {
    const char* dir = std::getenv("TMPDIR");
    std::string path = std::string(dir && *dir ? dir : "/tmp") + "/asi-gateway-gcode-XXXXXX";
    const int fd = ::mkstemp(path.data());
    if (fd < 0) {
        err << "asi-gateway gcode: cannot create a temporary file in " << (dir && *dir ? dir : "/tmp") << ": "
            << std::strerror(errno) << '\n';
        return false;
    }
    bool ok = true;
    char buf[64 * 1024];
    while (ok && std::cin) {
        std::cin.read(buf, sizeof buf);
        auto n = static_cast<std::size_t>(std::cin.gcount());
        for (const char* p = buf; n > 0;) {
            const ssize_t w = ::write(fd, p, n);
            if (w < 0 && errno == EINTR) continue;
            if (w < 0) {
                err << "asi-gateway gcode: cannot spool stdin to " << path << ": " << std::strerror(errno)
                    << '\n';
                ok = false;
                break;
            }
            p += w;
            n -= static_cast<std::size_t>(w);
        }
    }
    ::close(fd);
    if (ok) in.open(path, std::ios::binary);
    ::unlink(path.c_str());  // the open stream keeps the data
    return ok && in.is_open();
}

bool open_program(const std::string& file, std::ifstream& in, std::ostream& err) {
    if (file == "-") return spool_stdin(in, err);
    std::error_code ec;
    if (std::filesystem::is_directory(file, ec)) {
        err << "asi-gateway gcode: " << file << " is a directory\n";
        return false;
    }
    in.open(file, std::ios::binary);
    if (!in) {
        err << "asi-gateway gcode: cannot read " << file << ": " << std::strerror(errno) << '\n';
        return false;
    }
    return true;
}

// Applies every --set; the first problem as a message, or nothing.
std::optional<std::string> apply_settings(const std::vector<std::string>& settings,
                                          gcode::gcode_options& options, gcode::preview_options* preview) {
    for (const auto& s : settings) {
        const auto eq = s.find('=');
        if (eq == std::string::npos || eq == 0) return "--set " + s + ": expected NAME=VALUE";
        const std::string name = s.substr(0, eq);
        const std::string value = s.substr(eq + 1);
        if (preview) {
            auto r = gcode::set_preview_option(*preview, name, value);
            if (r.known) {
                if (r.error) return "--set " + s + ": " + *r.error;
                continue;
            }
        }
        if (auto why = gcode::set_option(options, name, value)) return "--set " + s + ": " + *why;
    }
    if (auto why = gcode::validate(options)) return "bad options: " + *why;
    return std::nullopt;
}

}  // namespace

gcode_cli::gcode_cli(CLI::App& app) {
    gcode_ = app.add_subcommand("gcode", "G-code programs without a controller (plan, preview)");
    gcode_->require_subcommand(1);
    plan_ = gcode_->add_subcommand("plan", "Print the plan of a G-code program as JSON");
    preview_ = gcode_->add_subcommand("preview", "Print the path of a G-code program as SVG");
    for (auto* sub : {plan_, preview_}) {
        sub->add_option("FILE", file_, "The program (- for stdin)")->required();
        sub->add_option("--set", settings_,
                        "An option NAME=VALUE (repeatable): xyz_scale, speed_scale, arc_tolerance_mm, "
                        "max_feed_mm_s, rapid_mm_s, decimal_point, z_mode, ... (gateway/gcode/README.md)");
    }
    plan_->add_flag("--summary", summary_, "Only the totals, bounds and warnings (no move list)");
    preview_->footer("Preview options for --set: view=XY|ZX|YZ, width_px=50..10000, max_points=100..1000000");
}

bool gcode_cli::selected() const {
    return gcode_->parsed();
}

int gcode_cli::run(std::ostream& out, std::ostream& err) const {
    return plan_->parsed() ? run_plan(out, err) : run_preview(out, err);
}

int gcode_cli::run_plan(std::ostream& out, std::ostream& err) const {
    gcode::gcode_options options;
    if (auto why = apply_settings(settings_, options, nullptr)) {
        err << "asi-gateway gcode plan: " << *why << '\n';
        return 2;
    }
    std::ifstream in;
    if (!open_program(file_, in, err)) return 2;
    const bool ok = summary_ ? gcode::write_plan_summary_json(in, options, out)
                             : gcode::write_plan_json(in, options, out);
    out << '\n';
    out.flush();
    if (!out) {
        err << "asi-gateway gcode plan: cannot write the plan to stdout\n";
        return 1;
    }
    return ok ? 0 : 2;
}

int gcode_cli::run_preview(std::ostream& out, std::ostream& err) const {
    gcode::gcode_options options;
    gcode::preview_options view;
    if (auto why = apply_settings(settings_, options, &view)) {
        err << "asi-gateway gcode preview: " << *why << '\n';
        return 2;
    }
    std::ifstream in;
    if (!open_program(file_, in, err)) return 2;
    if (auto e = gcode::write_preview_svg(in, options, view, out)) {
        gcode::write_error_json(err, *e);
        err << '\n';
        return 2;
    }
    out.flush();
    if (!out) {
        err << "asi-gateway gcode preview: cannot write the SVG to stdout\n";
        return 1;
    }
    return 0;
}

}  // namespace gw
