// A crash (the manager destroyed without shutdown, like kill -9 of the gateway) while a job has changed
// controller settings: the new manager finds the job's restore commands in the store and sends them
// under the recovery's request id, never as the job's. Without that an array's IN0 stays in ARRAY mode
// (TTL X=7) and a ring-buffer tour's in TTL X=1, so a later TTL edge moves the stage; a scan leaves its
// scan SPEED.
#include <algorithm>
#include <cmath>
#include <sqlite3.h>
#include <string>
#include <vector>

#include "gateway/jobs/kinds/safe_outputs.hpp"
#include "tests/integration/jobs/manager_fixture.hpp"

namespace gw::jobs::test {
namespace {

using json = nlohmann::json;

class restore_recovery_test : public manager_fixture {
  protected:
    double sim_um(const std::string& sim, char axis) {
        return sim_state(sim)["axes"][std::string(1, axis)]["position"].get<double>() / 10.0;
    }
    double sim_speed(const std::string& sim, char axis) {
        return sim_state(sim)["axes"][std::string(1, axis)]["speed"].get<double>();
    }
    int in0_mode(const std::string& sim) { return sim_state(sim)["ttl"]["in0_mode"].get<int>(); }
    bool wait_steps(const std::string& id, std::size_t n) {
        return wait_until([&] {
            auto j = job(id);
            return j && j->progress.steps_done >= n;
        });
    }
    // Commands sent under the recovery's request id (wire text without CR), in order.
    std::vector<std::string> recovery_of(const std::string& id) {
        return observer_->locked([&] {
            std::vector<std::string> out;
            for (const auto& t : observer_->traces)
                if (t.request_id == safe_output_request_id(id)) {
                    auto w = t.wire;
                    if (w.ends_with("\\r")) w.resize(w.size() - 2);
                    out.push_back(w);
                }
            return out;
        });
    }
    // The simulated controller has stood still (no move, no scan, no autoplay) for 300 ms.
    bool wait_quiet(const std::string& sim) {
        int still = 0;
        return wait_until([&] {
            const auto s = sim_state(sim);
            const auto flag = [&](const char* module, const char* key) {
                return s.contains(module) && s[module].value(key, false);
            };
            const bool quiet =
                !s.value("busy", true) && !flag("scan", "running") && !flag("ring_buffer", "autoplay");
            still = quiet ? still + 1 : 0;
            return still >= 30;
        });
    }
    // After the restart: nothing is sent as the job, and an IN0 edge moves nothing.
    void expect_no_job_commands_and_edges_move_nothing(const std::string& sim, const std::string& id) {
        ASSERT_TRUE(wait_quiet(sim));
        const auto as_job = commands_of(id);
        const double x = sim_um(sim, 'X');
        const double y = sim_um(sim, 'Y');
        sims_.at(sim)->ttl_pulse();
        std::this_thread::sleep_for(300ms);
        EXPECT_FALSE(sim_state(sim)["busy"].get<bool>());
        EXPECT_NEAR(sim_um(sim, 'X'), x, 1);
        EXPECT_NEAR(sim_um(sim, 'Y'), y, 1);
        EXPECT_EQ(commands_of(id), as_job);
        EXPECT_EQ(job(id)->state, job_state::interrupted);
    }
};

TEST_F(restore_recovery_test, a_crashed_firmware_array_run_gets_in0_back_and_later_edges_move_nothing) {
    add_sim("sim1", "full", 5);
    start();
    const int in0_before = in0_mode("sim1");
    auto submitted =
        submit("sim1", job_type::array, json::parse(R"({"grid": {"columns": 4, "rows": 3, "column_step_mm": 4,
                                                     "row_step_mm": 4}, "a1": {"X": 0, "Y": 0}})"));
    ASSERT_TRUE(submitted) << submitted.error().message;
    ASSERT_EQ(submitted->job.plan_path, "firmware");
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_steps(id, 2));
    ASSERT_EQ(in0_mode("sim1"), 7);  // the ARRAY module steps on IN0 edges

    restart_manager();
    ASSERT_TRUE(wait_state(id, job_state::interrupted));
    // HALT first (the run was moving when the gateway went down), then IN0 back.
    const std::vector<std::string> expected{"\\\\", "TTL X=" + std::to_string(in0_before)};
    ASSERT_TRUE(wait_until([&] { return recovery_of(id) == expected; }, 10s))
        << testing::PrintToString(recovery_of(id));
    EXPECT_EQ(in0_mode("sim1"), in0_before);
    expect_no_job_commands_and_edges_move_nothing("sim1", id);
    EXPECT_EQ(recovery_of(id), expected);  // once

    // A resumed run owns IN0 again and puts it back itself when it ends.
    ASSERT_TRUE(resume(id));
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 120s));
    EXPECT_EQ(in0_mode("sim1"), in0_before);
    EXPECT_EQ(recovery_of(id), expected);
}

TEST_F(restore_recovery_test, a_crashed_ttl_ring_buffer_tour_gets_in0_back_and_later_edges_move_nothing) {
    auto sim = add_sim("sim3", "planar");
    start();
    const int in0_before = in0_mode("sim3");
    auto spec = json::parse(R"({"positions": [{"X": 500, "Y": 0}, {"X": 1000, "Y": 500}, {"X": 0, "Y": 1000}],
                                "trigger": "ttl"})");
    auto submitted = submit("sim3", job_type::ring_buffer, spec);
    ASSERT_TRUE(submitted) << submitted.error().message;
    ASSERT_EQ(submitted->job.plan_path, "firmware");
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_until([&] { return in0_mode("sim3") == 1; }));
    sim->ttl_pulse();
    ASSERT_TRUE(wait_steps(id, 1));

    restart_manager();
    ASSERT_TRUE(wait_state(id, job_state::interrupted));
    // HALT first (the run was moving when the gateway went down), then IN0 back.
    const std::vector<std::string> expected{"\\\\", "TTL X=" + std::to_string(in0_before)};
    ASSERT_TRUE(wait_until([&] { return recovery_of(id) == expected; }, 10s))
        << testing::PrintToString(recovery_of(id));
    EXPECT_EQ(in0_mode("sim3"), in0_before);
    expect_no_job_commands_and_edges_move_nothing("sim3", id);
    EXPECT_EQ(recovery_of(id), expected);
}

// The store holds a run's restore commands only while they may be needed: from the registration until
// the run ends normally (it restores itself) or a cancel has sent them.
TEST_F(restore_recovery_test,
       the_stored_list_lives_while_the_run_does_and_is_cleared_when_it_ends_or_is_cancelled) {
    add_sim("sim1", "full", 5);
    start();
    const auto rows = [&](const std::string& id) {
        sqlite3* db = nullptr;
        EXPECT_EQ(sqlite3_open((dir_ + "/store/jobs.sqlite3").c_str(), &db), SQLITE_OK);
        sqlite3_stmt* s = nullptr;
        EXPECT_EQ(sqlite3_prepare_v2(db, "SELECT commands FROM job_restore_commands WHERE job_id = ?1", -1,
                                     &s, nullptr),
                  SQLITE_OK);
        sqlite3_bind_text(s, 1, id.c_str(), -1, SQLITE_TRANSIENT);
        std::vector<std::string> out;
        while (sqlite3_step(s) == SQLITE_ROW)
            out.emplace_back(reinterpret_cast<const char*>(sqlite3_column_text(s, 0)));
        sqlite3_finalize(s);
        sqlite3_close(db);
        return out;
    };
    const auto spec =
        json::parse(R"({"grid": {"columns": 3, "rows": 2, "column_step_mm": 4, "row_step_mm": 4},
                                      "a1": {"X": 0, "Y": 0}})");
    const std::vector<std::string> while_running{R"(["TTL X=0"])"};

    auto finished = submit("sim1", job_type::array, spec);
    ASSERT_TRUE(finished) << finished.error().message;
    const auto done_id = finished->job.id;
    ASSERT_TRUE(wait_steps(done_id, 1));
    EXPECT_EQ(rows(done_id), while_running);
    ASSERT_TRUE(wait_state(done_id, job_state::succeeded, 60s));
    EXPECT_TRUE(rows(done_id).empty());

    auto cancelled = submit("sim1", job_type::array, spec);
    ASSERT_TRUE(cancelled) << cancelled.error().message;
    const auto cancel_id = cancelled->job.id;
    ASSERT_TRUE(wait_steps(cancel_id, 1));
    EXPECT_EQ(rows(cancel_id), while_running);
    ASSERT_TRUE(cancel(cancel_id));
    ASSERT_TRUE(wait_state(cancel_id, job_state::cancelled));
    EXPECT_TRUE(rows(cancel_id).empty());

    // Neither is recovered by a restart.
    restart_manager();
    std::this_thread::sleep_for(300ms);
    EXPECT_TRUE(recovery_of(done_id).empty());
    EXPECT_TRUE(recovery_of(cancel_id).empty());
}

// The value a run puts back is what the controller had before any job changed it, read from the
// controller, never from the snapshot: after a gateway restart the drivers identify the controllers
// again, and the snapshot shows what the crashed run left (IN0 in ARRAY mode), even once the recovery
// has put it back. Each cycle one job changes IN0 or the scan SPEED, the whole gateway crashes, and
// the new one's recovery must bring back the settings from before the first job.
TEST_F(restore_recovery_test,
       twenty_gateway_crashes_in_a_row_end_with_the_settings_from_before_the_first_job) {
    // planar: the ARRAY and RING BUFFER modules step on IN0 edges; scans run host-driven.
    add_sim("sim1", "planar", 5);
    start();
    const int in0_before = in0_mode("sim1");
    const double speed_before = sim_speed("sim1", 'X');
    ASSERT_EQ(in0_before, 0);
    const auto array_spec = json::parse(R"({"grid": {"columns": 4, "rows": 3, "column_step_mm": 4,
                                             "row_step_mm": 4}, "a1": {"X": 0, "Y": 0}})");
    const auto tour_spec = json::parse(R"({"positions": [{"X": 500, "Y": 0}, {"X": 1000, "Y": 500}],
                                           "trigger": "ttl"})");
    const auto scan_spec = json::parse(R"({"fast": {"start_mm": 0, "stop_mm": 0.2, "encoder_divide": 24},
                                           "slow": {"start_mm": 0, "stop_mm": 0.2, "lines": 3},
                                           "speed_mm_s": 0.1})");
    for (int crash = 1; crash <= 20; ++crash) {
        SCOPED_TRACE("crash " + std::to_string(crash));
        std::string id;
        switch (crash % 3) {
            case 1: {  // a firmware array: IN0 in ARRAY mode
                auto submitted = submit("sim1", job_type::array, array_spec);
                ASSERT_TRUE(submitted) << submitted.error().message;
                ASSERT_EQ(submitted->job.plan_path, "firmware");
                id = submitted->job.id;
                ASSERT_TRUE(wait_until([&] { return in0_mode("sim1") == 7; }));
                break;
            }
            case 2: {  // a ring-buffer tour stepped by IN0 edges
                auto submitted = submit("sim1", job_type::ring_buffer, tour_spec);
                ASSERT_TRUE(submitted) << submitted.error().message;
                ASSERT_EQ(submitted->job.plan_path, "firmware");
                id = submitted->job.id;
                ASSERT_TRUE(wait_until([&] { return in0_mode("sim1") == 1; }));
                break;
            }
            default: {  // a host scan, at its own SPEED for each line
                auto submitted = submit("sim1", job_type::scan, scan_spec);
                ASSERT_TRUE(submitted) << submitted.error().message;
                id = submitted->job.id;
                ASSERT_TRUE(wait_until([&] { return std::abs(sim_speed("sim1", 'X') - 0.1) < 1e-6; }));
                break;
            }
        }

        restart_gateway();
        ASSERT_TRUE(wait_state(id, job_state::interrupted));
        ASSERT_TRUE(wait_until(
            [&] {
                return in0_mode("sim1") == in0_before &&
                       std::abs(sim_speed("sim1", 'X') - speed_before) < 1e-3;
            },
            10s))
            << "IN0 " << in0_mode("sim1") << ", SPEED X " << sim_speed("sim1", 'X') << "; the recovery sent "
            << testing::PrintToString(recovery_of(id));
        ASSERT_TRUE(wait_quiet("sim1"));  // the crashed run's last move ends
    }
    EXPECT_EQ(in0_mode("sim1"), in0_before);
    EXPECT_NEAR(sim_speed("sim1", 'X'), speed_before, 1e-3);
    EXPECT_EQ(sim_state("sim1")["ttl"]["out0_mode"], 0);
}

// With restart_queued, the job queued behind the crashed one starts right after the restart: it waits
// for the recovery, and what it puts back when it ends is IN0 from before the crashed run.
TEST_F(restore_recovery_test, a_queued_job_started_by_the_restart_puts_back_in0_from_before_the_crash) {
    restart_queued_ = true;
    add_sim("sim1", "full", 5);
    start();
    const int in0_before = in0_mode("sim1");
    const auto spec =
        json::parse(R"({"grid": {"columns": 3, "rows": 2, "column_step_mm": 4, "row_step_mm": 4},
                                      "a1": {"X": 0, "Y": 0}})");
    auto crashed = submit("sim1", job_type::array, spec);
    auto queued = submit("sim1", job_type::array, spec);
    ASSERT_TRUE(crashed && queued);
    ASSERT_TRUE(wait_until([&] { return in0_mode("sim1") == 7; }));

    restart_gateway();
    ASSERT_TRUE(wait_state(crashed->job.id, job_state::interrupted));
    ASSERT_TRUE(wait_state(queued->job.id, job_state::succeeded, 120s));
    EXPECT_EQ(in0_mode("sim1"), in0_before);
    EXPECT_EQ(commands_of(queued->job.id).back(), "TTL X=" + std::to_string(in0_before));
    // The recovery went out before the queued job changed IN0.
    const auto position = [&](const std::string& request_id, const std::string& wire) {
        return observer_->locked([&] {
            const auto& t = observer_->traces;
            return std::find_if(t.begin(), t.end(),
                                [&](const auto& c) { return c.request_id == request_id && c.wire == wire; }) -
                   t.begin();
        });
    };
    EXPECT_LT(position(safe_output_request_id(crashed->job.id), "TTL X=0\\r"),
              position("job-" + queued->job.id, "TTL X=7\\r"));
}

// Both scan paths change the fast axis's SPEED; the firmware path (ENC_INT) changes IN0 too.
class scan_restore_recovery_test : public restore_recovery_test,
                                   public ::testing::WithParamInterface<const char*> {};

TEST_P(scan_restore_recovery_test, a_crashed_scan_gets_its_speed_back) {
    const std::string preset = GetParam();
    add_sim("sim1", preset, 5);
    start();
    const double speed_before = sim_speed("sim1", 'X');
    const int in0_before = in0_mode("sim1");
    auto submitted = submit("sim1", job_type::scan,
                            json::parse(R"({"fast": {"start_mm": 0, "stop_mm": 0.2, "encoder_divide": 24},
                                            "slow": {"start_mm": 0, "stop_mm": 0.9, "lines": 10},
                                            "speed_mm_s": 0.1})"));
    ASSERT_TRUE(submitted) << submitted.error().message;
    ASSERT_EQ(submitted->job.plan_path, preset == "full" ? "firmware" : "host");
    const auto id = submitted->job.id;
    // The host path sets the scan speed for each line and puts it back for the return: crash mid-line.
    ASSERT_TRUE(wait_until([&] {
        auto j = job(id);
        return j && j->progress.steps_done >= 1 && std::abs(sim_speed("sim1", 'X') - 0.1) < 1e-6;
    })) << "the scan's speed never seen";

    restart_manager();
    ASSERT_TRUE(wait_state(id, job_state::interrupted));
    ASSERT_TRUE(wait_until([&] { return std::abs(sim_speed("sim1", 'X') - speed_before) < 1e-3; }, 10s))
        << "SPEED still " << sim_speed("sim1", 'X') << "; recovery sent "
        << testing::PrintToString(recovery_of(id));
    ASSERT_TRUE(wait_quiet("sim1"));
    const auto recovery = recovery_of(id);
    ASSERT_FALSE(recovery.empty());
    EXPECT_EQ(recovery.front(), "\\\\") << "HALT before anything else";
    EXPECT_TRUE(std::any_of(recovery.begin(), recovery.end(),
                            [](const std::string& c) { return c.starts_with("SPEED X="); }));
    EXPECT_TRUE(std::all_of(recovery.begin() + 1, recovery.end(), [](const std::string& c) {
        return c.starts_with("SPEED X=") || c.starts_with("TTL X=");
    })) << testing::PrintToString(recovery);
    EXPECT_EQ(std::count(recovery.begin(), recovery.end(), "TTL Y=0"), 0);  // no output to switch off
    EXPECT_EQ(in0_mode("sim1"), in0_before);
    EXPECT_NEAR(sim_speed("sim1", 'X'), speed_before, 1e-3);
    const auto as_job = commands_of(id);
    std::this_thread::sleep_for(300ms);
    EXPECT_EQ(commands_of(id), as_job);
    EXPECT_EQ(recovery_of(id), recovery);
}

INSTANTIATE_TEST_SUITE_P(paths, scan_restore_recovery_test, ::testing::Values("full", "plain"),
                         [](const auto& info) {
                             return std::string(info.param) == "full" ? "firmware" : "host";
                         });

// A firmware array (IN0 in ARRAY mode) two wells in, then its controller unplugged: the job pauses.
class unplugged_restore_test : public restore_recovery_test {
  protected:
    std::string run_then_unplug(bool ttl_pulse) {
        auto spec = json::parse(R"({"grid": {"columns": 4, "rows": 3, "column_step_mm": 4, "row_step_mm": 4},
                                    "a1": {"X": 0, "Y": 0}})");
        spec["ttl_pulse"] = ttl_pulse;
        auto submitted = submit("sim1", job_type::array, spec);
        EXPECT_TRUE(submitted) << submitted.error().message;
        if (!submitted) return {};
        EXPECT_EQ(submitted->job.plan_path, "firmware");
        const auto id = submitted->job.id;
        EXPECT_TRUE(wait_steps(id, 2));
        sims_.at("sim1")->unplug();
        EXPECT_TRUE(wait_state(id, job_state::paused));
        return id;
    }
};

// The gateway stops while the controller is unplugged, by a crash or a clean shutdown: nothing can be
// sent then or at start-up; the restore commands go once the controller is back (a run started before
// that would send them first).
class stopped_while_unplugged_test : public unplugged_restore_test,
                                     public ::testing::WithParamInterface<bool> {};

TEST_P(stopped_while_unplugged_test, restores_in0_once_the_controller_is_back) {
    const bool crash = GetParam();
    auto sim = add_sim("sim1", "full", 5);
    start();
    const int in0_before = in0_mode("sim1");
    const auto id = run_then_unplug(false);
    ASSERT_FALSE(id.empty());
    if (crash) {
        restart_manager();
    } else {
        shutdown_manager();
        manager_.reset();
        open_manager();
    }
    ASSERT_TRUE(wait_state(id, job_state::interrupted));
    std::this_thread::sleep_for(200ms);
    EXPECT_EQ(in0_mode("sim1"), 7);  // unreachable meanwhile
    sim->replug();
    // After a crash the job was still paused holding the controller: HALT goes first. A shutdown
    // interrupted it (and halted) on its way out.
    std::vector<std::string> expected{"TTL X=" + std::to_string(in0_before)};
    if (crash) expected.insert(expected.begin(), "\\\\");
    ASSERT_TRUE(wait_until([&] { return recovery_of(id) == expected; }, 30s))
        << testing::PrintToString(recovery_of(id));
    EXPECT_EQ(in0_mode("sim1"), in0_before);
    expect_no_job_commands_and_edges_move_nothing("sim1", id);
}

// A run that ended by a disconnect left its settings changed; the snapshot of the controller, identified
// again after the replug, shows them so. Its resumed run puts back what was there before its first run.
TEST_F(unplugged_restore_test,
       a_firmware_array_resumed_after_a_replug_ends_with_in0_as_before_its_first_run) {
    auto sim = add_sim("sim1", "full", 5);
    start();
    const int in0_before = in0_mode("sim1");
    const auto id = run_then_unplug(false);
    ASSERT_FALSE(id.empty());
    sim->replug();
    ASSERT_TRUE(wait_until([&] { return registry_->ready(); }));
    ASSERT_EQ(registry_->get("sim1")->ttl_in0_mode, 7);
    auto resumed = resume(id);
    ASSERT_TRUE(resumed) << resumed.error().message;
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 120s));
    EXPECT_EQ(in0_mode("sim1"), in0_before);
    EXPECT_EQ(commands_of(id).back(), "TTL X=" + std::to_string(in0_before));
}

// The same for the host scan's SPEED: unplugged mid-line, at the scan speed.
TEST_F(unplugged_restore_test,
       a_host_scan_resumed_after_a_replug_ends_with_the_speed_from_before_its_first_run) {
    auto sim = add_sim("sim1", "plain", 5);
    start();
    const double speed_before = sim_speed("sim1", 'X');
    auto submitted = submit("sim1", job_type::scan,
                            json::parse(R"({"fast": {"start_mm": 0, "stop_mm": 0.2, "encoder_divide": 24},
                                            "slow": {"start_mm": 0, "stop_mm": 0.4, "lines": 5},
                                            "speed_mm_s": 0.1})"));
    ASSERT_TRUE(submitted) << submitted.error().message;
    ASSERT_EQ(submitted->job.plan_path, "host");
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_until([&] {
        auto j = job(id);
        return j && j->progress.steps_done >= 1 && std::abs(sim_speed("sim1", 'X') - 0.1) < 1e-6;
    })) << "the scan's speed never seen";
    sim->unplug();
    ASSERT_TRUE(wait_state(id, job_state::paused));
    ASSERT_NEAR(sim_speed("sim1", 'X'), 0.1, 1e-6);
    sim->replug();
    ASSERT_TRUE(wait_until([&] { return registry_->ready(); }));
    auto resumed = resume(id);
    ASSERT_TRUE(resumed) << resumed.error().message;
    ASSERT_TRUE(wait_state(id, job_state::succeeded, 120s));
    EXPECT_NEAR(sim_speed("sim1", 'X'), speed_before, 1e-3);
}

INSTANTIATE_TEST_SUITE_P(crash_or_shutdown, stopped_while_unplugged_test, ::testing::Bool(),
                         [](const auto& info) { return info.param ? "crash" : "clean_shutdown"; });

// A cancel while unplugged: HALT, TTL Y=0 and the restore commands cannot be sent; the restore
// commands (and TTL Y=0 for a job that drives the output) go out once the controller is back.
TEST_F(unplugged_restore_test,
       a_cancel_while_unplugged_restores_in0_and_the_output_once_the_controller_is_back) {
    auto sim = add_sim("sim1", "full", 5);
    start();
    const int in0_before = in0_mode("sim1");
    const auto id = run_then_unplug(true);
    ASSERT_FALSE(id.empty());
    auto cancelled = cancel(id);
    ASSERT_TRUE(cancelled) << cancelled.error().message;
    ASSERT_TRUE(wait_state(id, job_state::cancelled));
    sim->replug();
    const std::vector<std::string> expected{"TTL Y=0", "TTL X=" + std::to_string(in0_before)};
    ASSERT_TRUE(wait_until([&] { return recovery_of(id) == expected; }, 30s))
        << testing::PrintToString(recovery_of(id));
    EXPECT_EQ(in0_mode("sim1"), in0_before);
    EXPECT_EQ(sim_state("sim1")["ttl"]["out0_mode"], 0);
    ASSERT_TRUE(wait_quiet("sim1"));
    EXPECT_EQ(recovery_of(id), expected);  // once
}

}  // namespace
}  // namespace gw::jobs::test
