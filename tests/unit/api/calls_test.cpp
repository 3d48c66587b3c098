#include "api/calls/calls.hpp"

#include <filesystem>
#include <optional>
#include <sstream>
#include <unistd.h>

#include <boost/asio/io_context.hpp>
#include <gtest/gtest.h>

#include "api/common/gcode_worker.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/storage/gcode_files.hpp"

namespace gw::api {
namespace {

// Calls on a context without controllers and without a job manager: what the dispatch itself decides.
class calls_test : public ::testing::Test {
  protected:
    calls_test()
        : registry_(io_.get_executor(), registry_options{}),
          ctx_{io_.get_executor(), registry_, nullptr, nullptr, {}, {}, nullptr, nullptr, nullptr} {}

    // The outcome of `c` for a caller with `role`; checks that it is never delivered inline.
    api_outcome dispatch(gw::role role, call c) {
        std::optional<api_outcome> out;
        dispatch_call(ctx_, caller{"ada", role, "rid-7", std::nullopt}, std::move(c),
                      [&out](api_outcome o) { out = std::move(o); });
        EXPECT_FALSE(out.has_value()) << "answered inline";
        io_.run();
        io_.restart();
        EXPECT_TRUE(out.has_value());
        return out ? std::move(*out) : api_outcome{};
    }

    boost::asio::io_context io_;
    controller_registry registry_;
    api_context ctx_;
};

TEST_F(calls_test, each_call_needs_its_role) {
    EXPECT_EQ(role_for(operation_call{"s1", "move", {}}), gw::role::operator_);
    EXPECT_EQ(role_for(operation_call{"s1", "command", {}}), gw::role::admin);
    EXPECT_EQ(role_for(operation_call{"s1", "halt", {}}), gw::role::viewer);
    EXPECT_EQ(role_for(operation_call{"s1", "halt", {}}, gw::role::operator_), gw::role::operator_);
    EXPECT_EQ(role_for(halt_all_call{}, gw::role::admin), gw::role::admin);
    EXPECT_EQ(role_for(job_submit_call{}), gw::role::operator_);
    EXPECT_EQ(role_for(job_action_call{"j-1", job_command::pause}), gw::role::operator_);
    EXPECT_EQ(role_for(job_get_call{"j-1"}), gw::role::viewer);
    EXPECT_EQ(role_for(lease_get_call{"s1"}), gw::role::viewer);
    EXPECT_EQ(role_for(lease_take_call{"s1", {}}), gw::role::operator_);
    EXPECT_EQ(role_for(lease_renew_call{"s1", {}}), gw::role::operator_);
    EXPECT_EQ(role_for(lease_release_call{"s1", false}), gw::role::operator_);
    EXPECT_EQ(role_for(lease_release_call{"s1", true}), gw::role::admin);
    EXPECT_EQ(role_for(gcode_check_call{"g-1", {}}), gw::role::viewer);
}

TEST_F(calls_test, a_role_too_low_is_403_whatever_the_transport) {
    for (auto [role, c] : {std::pair<gw::role, call>{gw::role::viewer, operation_call{"s1", "move", {}}},
                           {gw::role::operator_, operation_call{"s1", "command", {{"command", "V"}}}},
                           {gw::role::viewer, job_submit_call{}},
                           {gw::role::viewer, job_action_call{"j-1", job_command::cancel}},
                           {gw::role::viewer, lease_take_call{"s1", {}}},
                           {gw::role::operator_, lease_release_call{"s1", true}}}) {
        auto out = dispatch(role, c);
        ASSERT_TRUE(out.error);
        EXPECT_EQ(out.error->status, 403);
        EXPECT_EQ(out.error->request_id, "rid-7");
    }
}

TEST_F(calls_test, an_allowed_call_reaches_its_resource) {
    // No controllers: the operation is refused by the registry (404), not by the dispatch.
    auto op = dispatch(gw::role::operator_, operation_call{"s1", "halt", {}});
    ASSERT_TRUE(op.error);
    EXPECT_EQ(op.error->status, 404);
    // No job manager: the job calls answer what the job routes answer without one (503).
    auto get = dispatch(gw::role::viewer, job_get_call{"j-1"});
    ASSERT_TRUE(get.error);
    EXPECT_EQ(get.error->status, 503);
}

// The same context with a real G-code store in a temporary directory and the G-code thread.
class gcode_check_test : public calls_test {
  protected:
    gcode_check_test() {
        ctx_.gcode_files = std::make_shared<gcode_file_store>(gcode_file_store_settings{dir_});
        ctx_.gcode_thread = std::make_shared<gcode_worker>();
    }
    ~gcode_check_test() override {
        ctx_.gcode_thread->stop();
        std::filesystem::remove_all(dir_);
    }
    std::string save(const std::string& program) {
        std::istringstream in(program);
        auto saved = ctx_.gcode_files->save(in, "part.ngc");
        EXPECT_TRUE(saved) << (saved ? "" : saved.error().message);
        return saved ? saved->id : std::string();
    }
    // Waits for the G-code thread's answer (it posts it to io_).
    api_outcome check(const std::string& file, nlohmann::json options = nullptr) {
        std::optional<api_outcome> out;
        dispatch_call(ctx_, caller{"ada", gw::role::viewer, "rid-9", std::nullopt},
                      gcode_check_call{file, std::move(options)},
                      [&out](api_outcome o) { out = std::move(o); });
        EXPECT_FALSE(out.has_value()) << "answered inline";
        {
            auto work = boost::asio::make_work_guard(io_);  // the answer comes from another thread
            const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
            while (!out && std::chrono::steady_clock::now() < deadline)
                io_.run_one_for(std::chrono::milliseconds(100));
        }
        io_.restart();  // the guard's end stopped io_ (it ran out of work)
        EXPECT_TRUE(out.has_value()) << "no answer";
        return out ? std::move(*out) : api_outcome{};
    }
    std::filesystem::path dir_ =
        std::filesystem::temp_directory_path() / ("gw-calls-gcode-" + std::to_string(::getpid()));
};

TEST_F(gcode_check_test, a_stored_program_answers_with_its_plan_summary) {
    const auto id = save("G21 G90\nG1 X10 Y0 F600\nG1 X10 Y5\n");
    auto out = check(id);
    ASSERT_FALSE(out.error) << out.error->detail;
    EXPECT_EQ(out.body.value("move_count", 0), 2) << out.body.dump();
    EXPECT_FALSE(out.body.contains("moves")) << "the summary, not the move list";
    // An option changes the plan: the scale reaches the bounds.
    auto scaled = check(id, {{"xyz_scale", 2}});
    ASSERT_FALSE(scaled.error) << scaled.error->detail;
    EXPECT_NE(scaled.body.dump(), out.body.dump());
}

TEST_F(gcode_check_test, refusals_name_what_is_wrong) {
    const auto bad = save("G21\nG1 X1 Q7\n");
    auto e = check(bad);
    ASSERT_TRUE(e.error);
    EXPECT_EQ(e.error->status, 422);
    EXPECT_EQ(e.error->kind, "invalid_gcode");
    ASSERT_TRUE(e.error->program);
    EXPECT_EQ(e.error->program->line, 2);
    EXPECT_EQ(e.error->request_id, "rid-9");

    auto missing = check("g-00000000000000000000000000");
    ASSERT_TRUE(missing.error);
    EXPECT_EQ(missing.error->status, 404);

    const auto good = save("G1 X1\n");
    for (const auto& [options, field] :
         {std::pair<nlohmann::json, std::string>{{{"moves", false}}, "options.moves"},
          {{{"xyz_scale", nlohmann::json::array()}}, "options.xyz_scale"},
          {{{"no_such_option", 1}}, "options.no_such_option"},
          {nlohmann::json::array(), "options"}}) {
        auto r = check(good, options);
        ASSERT_TRUE(r.error) << options.dump();
        EXPECT_EQ(r.error->status, 422) << options.dump();
        EXPECT_EQ(r.error->field, field) << options.dump();
    }
}

}  // namespace
}  // namespace gw::api
