// The array job's spec parsing and planning (array_spec.hpp, plan_array / plan_job): field errors,
// firmware/host choice, targets, estimates, command previews, resume_from, soft limits.
#include <algorithm>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "devices/sim/sim_config.hpp"
#include "gateway/jobs/kinds/array_spec.hpp"
#include "gateway/jobs/kinds/job_kinds.hpp"

namespace gw::jobs {
namespace {

using json = nlohmann::json;
using kind = operation_error_kind;

devices::controller_snapshot snapshot(const std::string& preset, double x_um = 1000, double y_um = -2000) {
    devices::controller_snapshot s;
    s.id = "sim1";
    s.state = devices::connection_state::connected;
    devices::controller_identity id;
    id.version = "9.50";
    id.build = devices::sim::make_build_info(devices::sim::preset(preset).value());
    s.identity = id;
    for (const char a : id.build.motor_axes) {
        devices::axis_state ax;
        ax.axis = a;
        ax.position_um = a == 'X' ? x_um : a == 'Y' ? y_um : 0;
        ax.lower_limit_mm = -200;
        ax.upper_limit_mm = 200;
        s.axes.push_back(ax);
    }
    s.ttl_in0_mode = 0;
    return s;
}

plan_context context(const std::string& preset) {
    return plan_context{snapshot(preset), motion_model{}, {}};
}

TEST(ArraySpec, Errors) {
    struct row {
        json spec;
        std::string field;
    };
    const std::vector<row> cases{
        {json::array(), "spec"},
        {{{"plate", "96"}, {"colour", "red"}}, "spec.colour"},
        {json::object(), "spec.plate"},
        {{{"plate", "96"}, {"grid", {{"columns", 2}}}}, "spec.grid"},
        {{{"plate", "95"}}, "spec.plate"},
        {{{"plate", true}}, "spec.plate"},
        {{{"grid", {{"columns", 2}, {"rows", 2}, {"column_step_mm", 1}}}}, "spec.grid.row_step_mm"},
        {{{"grid", {{"columns", 0}, {"rows", 2}, {"column_step_mm", 1}, {"row_step_mm", 1}}}},
         "spec.grid.columns"},
        {{{"grid", {{"columns", 2.5}, {"rows", 2}, {"column_step_mm", 1}, {"row_step_mm", 1}}}},
         "spec.grid.columns"},
        {{{"grid", {{"columns", 2}, {"rows", 703}, {"column_step_mm", 1}, {"row_step_mm", 1}}}},
         "spec.grid.rows"},
        {{{"grid", {{"columns", 2}, {"rows", 2}, {"column_step_mm", 0}, {"row_step_mm", 1}}}},
         "spec.grid.column_step_mm"},
        {{{"grid", {{"columns", 2}, {"rows", 2}, {"column_step_mm", 1}, {"row_step_mm", "1"}}}},
         "spec.grid.row_step_mm"},
        {{{"grid", {{"columns", 2}, {"rows", 2}, {"column_step_mm", 1}, {"row_step_mm", 1}, {"pitch", 1}}}},
         "spec.grid.pitch"},
        {{{"plate", "96"}, {"a1", "here"}}, "spec.a1"},
        {{{"plate", "96"}, {"a1", {{"X", 1}}}}, "spec.a1.Y"},
        {{{"plate", "96"}, {"a1", {{"X", 1}, {"Y", 2}, {"Z", 3}}}}, "spec.a1.Z"},
        {{{"plate", "96"}, {"a1", {{"X", "1"}, {"Y", 2}}}}, "spec.a1.X"},
        {{{"plate", "96"}, {"a1", {{"X", 1}, {"Y", 2e9}}}}, "spec.a1.Y"},
        {{{"plate", "96"}, {"rotation_deg", 400}}, "spec.rotation_deg"},
        {{{"plate", "96"}, {"order", "zigzag"}}, "spec.order"},
        {{{"plate", "96"}, {"wells", json::array()}}, "spec.wells"},
        {{{"plate", "96"}, {"wells", {"A1", "B3", "I1"}}}, "spec.wells[2]"},
        {{{"plate", "96"}, {"wells", {"A1", "a1"}}}, "spec.wells[1]"},
        {{{"plate", "96"}, {"wells", {"A1", 7}}}, "spec.wells[1]"},
        {{{"plate", "96"}, {"dwell_ms", -1}}, "spec.dwell_ms"},
        {{{"plate", "96"}, {"dwell_ms", "100"}}, "spec.dwell_ms"},
        {{{"plate", "96"}, {"dwell_ms", 2.5}}, "spec.dwell_ms"},  // whole milliseconds (openapi: integer)
        {{{"plate", "96"}, {"dwell_ms", 86400001}}, "spec.dwell_ms"},
        {{{"plate", "96"}, {"advance", "button"}}, "spec.advance"},
        {{{"plate", "96"}, {"ttl_pulse", 1}}, "spec.ttl_pulse"},
        {{{"plate", "96"}, {"resume_from", "Z99"}}, "spec.resume_from"},
        {{{"plate", "96"}, {"wells", {"A1", "B2"}}, {"resume_from", "C7"}}, "spec.resume_from"},
        {{{"plate", "96"}, {"mode", "turbo"}}, "spec.mode"},
    };
    for (const auto& c : cases) {
        const auto r = parse_array_spec(c.spec);
        ASSERT_FALSE(r) << c.spec.dump();
        EXPECT_EQ(r.error().kind, kind::invalid_value) << c.spec.dump();
        EXPECT_EQ(r.error().field, c.field) << c.spec.dump() << ": " << r.error().message;
        EXPECT_FALSE(r.error().message.empty());
    }
}

TEST(ArraySpec, AWholeNumberWrittenAsAFloatIsAnInteger) {
    // JSON Schema counts 250.0 as an integer; some clients write every number as a float.
    const auto whole = parse_array_spec({{"plate", "96"}, {"dwell_ms", 250.0}});
    ASSERT_TRUE(whole) << whole.error().message;
    EXPECT_EQ(whole->dwell_ms, 250);
    for (const double bad : {250.5, 86400001.0, 1e300, -1.0}) {
        const auto r = parse_array_spec({{"plate", "96"}, {"dwell_ms", bad}});
        ASSERT_FALSE(r) << bad;
        EXPECT_EQ(r.error().field, "spec.dwell_ms") << bad;
    }
}

TEST(ArraySpec, DefaultsAndEveryField) {
    const auto d = parse_array_spec({{"plate", "96"}});
    ASSERT_TRUE(d);
    EXPECT_EQ(d->geometry, (plate_geometry{12, 8, 9.0, -9.0}));
    EXPECT_FALSE(d->a1_um);
    EXPECT_EQ(d->order, well_order::serpentine);
    EXPECT_EQ(d->advance, advance_source::timer);
    EXPECT_EQ(d->mode, run_mode::automatic);
    EXPECT_EQ(d->visits().size(), 96u);

    const auto s = parse_array_spec(
        {{"grid", {{"columns", 3}, {"rows", 2}, {"column_step_mm", 2.5}, {"row_step_mm", 4}}},
         {"a1", {{"X", 100}, {"Y", -50}}},
         {"rotation_deg", 10},
         {"order", "raster"},
         {"wells", {"B1", "A3", "A1"}},
         {"dwell_ms", 250},
         {"advance", "next"},
         {"ttl_pulse", true},
         {"resume_from", "A3"},
         {"mode", "host"}});
    ASSERT_TRUE(s) << s.error().message;
    EXPECT_EQ(s->geometry, (plate_geometry{3, 2, 2.5, 4}));
    EXPECT_EQ(s->a1_um, (std::pair<double, double>{100, -50}));
    EXPECT_EQ(s->advance, advance_source::next);
    EXPECT_TRUE(s->ttl_pulse);
    EXPECT_EQ(s->mode, run_mode::host);
    // The subset is visited in plate order, whatever order it was given in.
    const auto v = s->visits();
    ASSERT_EQ(v.size(), 3u);
    EXPECT_EQ(well_name(v[0]), "A1");
    EXPECT_EQ(well_name(v[1]), "A3");
    EXPECT_EQ(well_name(v[2]), "B1");
    EXPECT_EQ(parse_array_spec({{"plate", 384}})->geometry.columns, 24);  // a number is accepted too
}

std::vector<std::string> step_names(const job_plan& p) {
    std::vector<std::string> out;
    for (const auto& s : p.steps)
        out.push_back(s.name);
    return out;
}

TEST(ArrayPlan, PathChoice) {
    struct row {
        json spec;
        std::string preset;
        std::optional<std::string> path;  // empty: an error
        kind error = kind::internal;
        std::string field{};
    };
    const std::vector<row> cases{
        {{{"plate", "96"}}, "full", "firmware"},
        {{{"plate", "96"}}, "plain", "host"},
        {{{"plate", "96"}, {"rotation_deg", 1.5}}, "full", "host"},
        {{{"plate", "96"}, {"wells", {"A1"}}}, "full", "host"},
        {{{"plate", "96"}, {"order", "raster"}}, "full", "host"},
        {{{"plate", "96"}, {"mode", "host"}}, "full", "host"},
        {{{"plate", "96"}, {"mode", "firmware"}}, "xy", "firmware"},
        {{{"plate", "96"}, {"mode", "firmware"}}, "plain", std::nullopt, kind::missing_module, "spec.mode"},
        {{{"plate", "96"}, {"mode", "firmware"}, {"rotation_deg", 2}},
         "full",
         std::nullopt,
         kind::invalid_value,
         "spec.rotation_deg"},
        {{{"plate", "96"}, {"mode", "firmware"}, {"wells", {"A1", "B2"}}},
         "full",
         std::nullopt,
         kind::invalid_value,
         "spec.wells"},
        {{{"plate", "96"}, {"mode", "firmware"}, {"order", "raster"}},
         "full",
         std::nullopt,
         kind::invalid_value,
         "spec.order"},
        // TTL advance: host-driven needs TTL_REPORT frames to see the edges; the ARRAY module does not.
        {{{"plate", "96"}, {"advance", "ttl"}}, "xy", "firmware"},
        {{{"plate", "96"}, {"advance", "ttl"}, {"mode", "host"}}, "full", "host"},
        {{{"plate", "96"}, {"advance", "ttl"}}, "plain", std::nullopt, kind::missing_module, "spec.advance"},
    };
    for (const auto& c : cases) {
        const auto p = plan_array(c.spec, context(c.preset));
        if (c.path) {
            ASSERT_TRUE(p) << c.spec.dump() << " " << c.preset << ": " << p.error().message;
            EXPECT_EQ(p->path, *c.path) << c.spec.dump() << " " << c.preset;
        } else {
            ASSERT_FALSE(p) << c.spec.dump() << " " << c.preset;
            EXPECT_EQ(p.error().kind, c.error) << c.spec.dump();
            EXPECT_EQ(p.error().field, c.field) << c.spec.dump() << ": " << p.error().message;
        }
    }
    // Falling back to the host path says why.
    const auto p = plan_array({{"plate", "96"}, {"order", "raster"}}, context("full"));
    ASSERT_TRUE(p);
    EXPECT_TRUE(std::any_of(p->warnings.begin(), p->warnings.end(), [](const std::string& w) {
        return w.find("serpentine only") != std::string::npos;
    }));
}

TEST(ArrayPlan, FirmwarePlanOf96Wells) {
    const auto p = plan_array({{"plate", "96"}, {"a1", {{"X", 14380}, {"Y", -11240}}}, {"dwell_ms", 100}},
                              context("full"));
    ASSERT_TRUE(p) << p.error().message;
    EXPECT_EQ(p->path, "firmware");
    ASSERT_EQ(p->steps.size(), 96u);
    const auto names = step_names(*p);
    EXPECT_EQ(names[0], "A1");
    EXPECT_EQ(names[12], "B12");
    EXPECT_EQ(names[95], "H1");
    ASSERT_TRUE(p->steps[12].target);
    EXPECT_NEAR(p->steps[12].target->at('X'), 14380 + 99000, 1e-6);
    EXPECT_NEAR(p->steps[12].target->at('Y'), -11240 - 9000, 1e-6);
    ASSERT_GE(p->commands.size(), 5u);
    EXPECT_EQ(p->commands[0], "TTL X=7");
    EXPECT_EQ(p->commands[1], "ARRAY X=12 Y=8 Z=9 F=-9");
    EXPECT_EQ(p->commands[2], "AHOME X=14.38 Y=-11.24");
    EXPECT_EQ(p->commands[3], "RM X=0");
    EXPECT_EQ(p->commands[4], "RM");
    EXPECT_EQ(std::count(p->commands.begin(), p->commands.end(), "RM"), 95);
    EXPECT_EQ(p->commands.back(), "TTL X=0");  // the IN0 mode it had before
    EXPECT_EQ(p->bounds.min.at('X'), 14380);
    EXPECT_EQ(p->bounds.max.at('X'), 14380 + 99000);
    EXPECT_EQ(p->bounds.max.at('Y'), -11240);
    EXPECT_EQ(p->bounds.min.at('Y'), -11240 - 63000);
    // Every step: its move from the previous position plus the dwell; the first from (1000, -2000).
    const motion_model m;
    EXPECT_NEAR(p->steps[0].estimated_s, m.move_seconds({{'X', 13.38}, {'Y', -9.24}}) + 0.1, 1e-9);
    EXPECT_NEAR(p->steps[1].estimated_s, m.move_seconds({{'X', 9.0}}) + 0.1, 1e-9);
    EXPECT_NEAR(p->steps[12].estimated_s, m.move_seconds({{'Y', -9.0}}) + 0.1, 1e-9);
    double sum = 0;
    for (const auto& s : p->steps) {
        sum += s.estimated_s;
        EXPECT_FALSE(s.waits_for_trigger);
    }
    EXPECT_NEAR(p->estimated_s, sum, 1e-9);
    EXPECT_NE(p->summary.find("96 wells"), std::string::npos) << p->summary;
    EXPECT_NE(p->summary.find("firmware"), std::string::npos) << p->summary;
}

TEST(ArrayPlan, HostPlanWithRotationSubsetAndPulse) {
    const auto p = plan_array({{"plate", "24"},
                               {"a1", {{"X", 0}, {"Y", 0}}},
                               {"rotation_deg", 90},
                               {"wells", {"B2", "A1"}},
                               {"ttl_pulse", true},
                               {"advance", "next"}},
                              context("full"));
    ASSERT_TRUE(p) << p.error().message;
    EXPECT_EQ(p->path, "host");
    EXPECT_EQ(step_names(*p), (std::vector<std::string>{"A1", "B2"}));
    // B2 = (+19.3 mm, -19.3 mm) rotated 90 degrees: (19.3, 19.3) mm.
    EXPECT_NEAR(p->steps[1].target->at('X'), 19300, 1e-6);
    EXPECT_NEAR(p->steps[1].target->at('Y'), 19300, 1e-6);
    EXPECT_FALSE(p->steps[0].waits_for_trigger);
    EXPECT_TRUE(p->steps[1].waits_for_trigger);
    EXPECT_EQ(p->commands, (std::vector<std::string>{"M X=0 Y=0", "TTL Y=1", "TTL Y=0", "M X=193000 Y=193000",
                                                     "TTL Y=1", "TTL Y=0"}));
}

TEST(ArrayPlan, CurrentPositionIsA1AndResumeFrom) {
    const auto p = plan_array({{"plate", "96"}, {"resume_from", "A3"}, {"mode", "host"}}, context("full"));
    ASSERT_TRUE(p) << p.error().message;
    ASSERT_EQ(p->steps.size(), 96u);
    EXPECT_FALSE(p->steps[0].target);
    EXPECT_FALSE(p->steps[1].target);
    EXPECT_EQ(p->steps[0].estimated_s, 0);
    ASSERT_TRUE(p->steps[2].target);
    EXPECT_NEAR(p->steps[2].target->at('X'), 1000 + 18000, 1e-6);  // A1 = the snapshot's (1000, -2000)
    EXPECT_NEAR(p->steps[2].target->at('Y'), -2000, 1e-6);
    EXPECT_EQ(p->commands.front(), "M X=190000 Y=-20000");
    EXPECT_NE(p->summary.find("resuming at A3"), std::string::npos) << p->summary;
    EXPECT_NE(p->summary.find("94 wells"), std::string::npos) << p->summary;

    // The firmware path goes to the resume well with AIJ.
    const auto f = plan_array({{"plate", "96"}, {"resume_from", "B11"}}, context("full"));
    ASSERT_TRUE(f);
    EXPECT_EQ(f->path, "firmware");
    EXPECT_EQ(f->commands[3], "AIJ X=11 Y=2");
}

TEST(ArrayPlan, SoftLimitsNameTheWell) {
    auto ctx = context("full");
    for (auto& a : ctx.snapshot.axes)
        a.upper_limit_mm = 50;  // X beyond 50 mm is out
    const auto p = plan_job(job_type::array, {{"plate", "96"}, {"a1", {{"X", 0}, {"Y", 0}}}}, ctx);
    ASSERT_FALSE(p);
    EXPECT_EQ(p.error().kind, kind::invalid_value);
    EXPECT_NE(p.error().message.find("A7"), std::string::npos) << p.error().message;  // X = 54 mm
    EXPECT_EQ(p.error().field, "spec.steps[6]");
}

TEST(ArrayPlan, NeedsXYAndAKnownPosition) {
    auto ctx = context("full");
    ctx.snapshot.axes[0].position_um.reset();
    const auto p = plan_array({{"plate", "96"}}, ctx);
    ASSERT_FALSE(p);
    EXPECT_EQ(p.error().field, "spec.a1");
    EXPECT_TRUE(plan_array({{"plate", "96"}, {"a1", {{"X", 0}, {"Y", 0}}}}, ctx));
}

}  // namespace
}  // namespace gw::jobs
