// Differential test against LinuxCNC's interpreter: each program of corpus/*.ngc (the subset both
// understand: straight moves, arcs in the three planes, incremental mode, units) is run through
// `rs274 -g` (Debian package linuxcnc-uspace) and through plan_program(); the end points, arc
// centres, planes and directions must agree. rs274 prints 4 decimals in program units, hence the
// tolerance. Skipped when rs274 is not installed.
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <unistd.h>
#include <vector>

#include <gtest/gtest.h>

#include "gateway/gcode/gcode_planner.hpp"

namespace gw::gcode {
namespace {

namespace fs = std::filesystem;

struct reference_move {
    std::string kind;  // "rapid", "linear", "arc"
    vec3 end;
    arc_plane plane = arc_plane::xy;
    double center_a = 0;  // in plane order
    double center_b = 0;
    bool ccw = false;
    double tolerance_mm = 0;
};

std::string rs274_path() {
    for (const char* p : {"/usr/bin/rs274", "/opt/lcnc/usr/bin/rs274"})
        if (fs::exists(p)) return p;
    return {};
}

std::string run(const std::string& command) {
    std::string out;
    std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(command.c_str(), "r"), pclose);
    if (!pipe) return out;
    std::array<char, 4096> buf{};
    std::size_t n = 0;
    while ((n = std::fread(buf.data(), 1, buf.size(), pipe.get())) > 0)
        out.append(buf.data(), n);
    return out;
}

std::vector<double> args_of(const std::string& line, const std::string& call) {
    std::vector<double> v;
    const auto open = line.find(call + "(");
    std::size_t i = open + call.size() + 1;
    const auto close = line.find(')', i);
    while (i < close) {
        std::size_t comma = line.find(',', i);
        if (comma == std::string::npos || comma > close) comma = close;
        v.push_back(std::stod(line.substr(i, comma - i)));
        i = comma + 1;
    }
    return v;
}

// The canonical calls of rs274, in millimetres, zero-length straight moves dropped (the planner drops them).
// rs274 maps its tool table into $HOME/.tool.mmap, so every run gets its own home: parallel runs
// sharing one truncate each other's mapping and die of SIGBUS with no output.
std::vector<reference_move> reference(const std::string& rs274, const fs::path& program,
                                      const fs::path& home) {
    std::vector<reference_move> moves;
    const fs::path tools = home / "tool.tbl";
    std::ofstream(tools) << "T1 P1 Z0 D0.125 ;dummy\n";
    const std::string out = run("HOME=" + home.string() + " " + rs274 + " -g -t " + tools.string() + " " +
                                program.string() + " 2>/dev/null");
    double scale = 1;
    arc_plane plane = arc_plane::xy;
    vec3 at{};
    std::size_t start = 0;
    while (start < out.size()) {
        std::size_t end = out.find('\n', start);
        if (end == std::string::npos) end = out.size();
        const std::string line = out.substr(start, end - start);
        start = end + 1;
        if (line.find("USE_LENGTH_UNITS(CANON_UNITS_INCHES)") != std::string::npos) scale = 25.4;
        if (line.find("USE_LENGTH_UNITS(CANON_UNITS_MM)") != std::string::npos) scale = 1;
        if (line.find("SELECT_PLANE(CANON_PLANE_XY)") != std::string::npos) plane = arc_plane::xy;
        if (line.find("SELECT_PLANE(CANON_PLANE_XZ)") != std::string::npos) plane = arc_plane::zx;
        if (line.find("SELECT_PLANE(CANON_PLANE_YZ)") != std::string::npos) plane = arc_plane::yz;
        const double tol = 0.00005 * scale * 1.5;  // half the last printed digit, and some
        for (const char* call : {"STRAIGHT_TRAVERSE", "STRAIGHT_FEED"}) {
            if (line.find(std::string(call) + "(") == std::string::npos) continue;
            const auto a = args_of(line, call);
            const vec3 p{a.at(0) * scale, a.at(1) * scale, a.at(2) * scale};
            if (distance(p, at) > 1e-9) {
                moves.push_back({call[9] == 'T' ? "rapid" : "linear", p, plane, 0, 0, false, tol});
            }
            at = p;
        }
        if (line.find("ARC_FEED(") != std::string::npos) {
            const auto a = args_of(line, "ARC_FEED");
            // (first_end, second_end, first_centre, second_centre, rotation, normal_end, ...)
            const vec3 p = from_plane({a.at(0) * scale, a.at(1) * scale, a.at(5) * scale}, plane);
            moves.push_back({"arc", p, plane, a.at(2) * scale, a.at(3) * scale, a.at(4) > 0, tol});
            at = p;
        }
    }
    return moves;
}

class collecting_sink final : public move_sink {
  public:
    std::vector<planned_move> moves;
    void on_move(const planned_move& m) override {
        if (m.kind == move_kind::rapid || m.kind == move_kind::linear || m.kind == move_kind::arc)
            moves.push_back(m);
    }
};

std::vector<fs::path> corpus() {
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(GW_GCODE_CORPUS_DIR))
        if (e.path().extension() == ".ngc") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    return files;
}

class rs274_diff_test : public ::testing::TestWithParam<fs::path> {};

TEST_P(rs274_diff_test, agrees_with_linuxcnc) {
    const std::string rs274 = rs274_path();
    if (rs274.empty()) GTEST_SKIP() << "rs274 not installed (Debian package linuxcnc-uspace)";
    const fs::path home = fs::temp_directory_path() /
                          ("gw_rs274_" + std::to_string(::getpid()) + "_" + GetParam().stem().string());
    fs::create_directories(home);
    const auto expected = reference(rs274, GetParam(), home);
    fs::remove_all(home);
    ASSERT_FALSE(expected.empty()) << "rs274 printed no motion for " << GetParam();

    std::ifstream in(GetParam());
    collecting_sink sink;
    const auto result = plan_program(in, gcode_options{}, sink);
    if (const auto* e = std::get_if<gcode_error>(&result))
        FAIL() << GetParam() << ":" << e->line << ":" << e->column << ": " << e->message;

    ASSERT_EQ(sink.moves.size(), expected.size());
    for (std::size_t i = 0; i < expected.size(); ++i) {
        const auto& r = expected[i];
        const auto& m = sink.moves[i];
        SCOPED_TRACE("move " + std::to_string(i) + " (line " + std::to_string(m.line) + ")");
        EXPECT_EQ(to_string(m.kind), r.kind);
        EXPECT_NEAR(m.end.x, r.end.x, r.tolerance_mm);
        EXPECT_NEAR(m.end.y, r.end.y, r.tolerance_mm);
        EXPECT_NEAR(m.end.z, r.end.z, r.tolerance_mm);
        if (m.kind != move_kind::arc) continue;
        EXPECT_EQ(m.arc.plane, r.plane);
        const plane_point c = to_plane(m.arc.center, m.arc.plane);
        EXPECT_NEAR(c.a, r.center_a, r.tolerance_mm);
        EXPECT_NEAR(c.b, r.center_b, r.tolerance_mm);
        EXPECT_EQ(m.arc.direction == arc_direction::ccw, r.ccw);
    }
}

INSTANTIATE_TEST_SUITE_P(corpus, rs274_diff_test, ::testing::ValuesIn(corpus()),
                         [](const auto& info) { return info.param.stem().string(); });

}  // namespace
}  // namespace gw::gcode
