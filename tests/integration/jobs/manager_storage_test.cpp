// The job manager when its store stops taking writes while it runs: a store that fills up (a real
// SQLite file at its storage.max_size_mb, filled by a second connection), and writes that fail as a full
// disk or a read-only remount would (the failing_vfs fake: a real disk cannot do that on demand). A
// submission is refused (storage_unavailable) and the service goes on; a running job pauses after the
// current step with the reason "storage unavailable: ..." and sends nothing more; a resume is refused
// until the store takes the history again, then the job continues and every step is stored once.
#include <algorithm>
#include <filesystem>
#include <sqlite3.h>

#include "tests/integration/jobs/manager_fixture.hpp"
#include "tests/support/failing_vfs.hpp"

namespace gw::jobs::test {
namespace {

using json = nlohmann::json;
using kind = operation_error_kind;

// A host-driven row of wells 0.2 mm apart that waits for a `next` call before every well after the
// first: each step happens when the test says so.
json next_row(int wells) {
    return {{"grid", {{"columns", wells}, {"rows", 1}, {"column_step_mm", 0.2}, {"row_step_mm", -0.2}}},
            {"a1", {{"X", 0}, {"Y", 0}}},
            {"advance", "next"},
            {"mode", "host"}};
}

class manager_storage_failure_test : public manager_fixture {
  protected:
    std::string database() const { return dir_ + "/store/jobs.sqlite3"; }

    std::size_t steps_done(const std::string& id) {
        auto j = job(id);
        return j ? j->progress.steps_done : 0;
    }

    // A row of `wells` wells that waits for `next` at each, submitted and at its first well; empty when
    // that failed (the failure is reported).
    std::string run_row_to_first_well(std::size_t wells) {
        auto submitted = submit("sim1", job_type::array, next_row(static_cast<int>(wells)));
        EXPECT_TRUE(submitted) << submitted.error().message;
        if (!submitted) return {};
        const auto id = submitted->job.id;
        EXPECT_TRUE(wait_until([&] { return steps_done(id) == 1; })) << "the first well was never reached";
        return id;
    }

    // One `next`, then the step it allows: true when the job paused after it.
    bool step_once(const std::string& id) {
        const auto before = steps_done(id);
        EXPECT_TRUE(next(id));
        EXPECT_TRUE(wait_until([&] { return steps_done(id) > before; })) << "no step after `next`";
        // The pause follows the step on the manager's strand at once.
        return wait_until([&] { return job(id)->state == job_state::paused; }, 300ms);
    }

    // The stored events of a job.
    std::vector<json> stored_events(const std::string& id) {
        auto e = manager_->events(id, 10000);
        EXPECT_TRUE(e) << e.error().message;
        return e ? *e : std::vector<json>{};
    }

    // The step indexes of the stored events, in stored order.
    std::vector<std::size_t> stored_steps(const std::string& id) {
        std::vector<std::size_t> out;
        for (const auto& e : stored_events(id))
            if (e.value("type", "") == "step") out.push_back(e.at("index").get<std::size_t>());
        return out;
    }

    // The states of the stored state events, in stored order; a state event that repeats the state
    // (waiting_for changed: a `next` wait, the store back) counts once.
    std::vector<std::string> stored_states(const std::string& id) {
        std::vector<std::string> out;
        for (const auto& e : stored_events(id))
            if (e.value("type", "") == "state" && (out.empty() || out.back() != e.value("state", "")))
                out.push_back(e.value("state", ""));
        return out;
    }

    static std::vector<std::size_t> all_steps(std::size_t n) {
        std::vector<std::size_t> out(n);
        for (std::size_t i = 0; i < n; ++i)
            out[i] = i;
        return out;
    }

    // While paused, the job sends nothing to its controller.
    void expect_silence(const std::string& id) {
        const auto sent = commands_of(id).size();
        std::this_thread::sleep_for(400ms);
        EXPECT_EQ(commands_of(id).size(), sent) << "a paused job sent commands";
        EXPECT_EQ(job(id)->state, job_state::paused);
    }

    // `next` for every well left; the job then succeeds.
    void finish(const std::string& id, std::size_t wells) {
        for (auto left = wells - steps_done(id); left > 0; --left)
            ASSERT_TRUE(next(id));
        ASSERT_TRUE(wait_state(id, job_state::succeeded));
    }

    // Moves sent for the job ("M X=.. Y=.."): one per well.
    std::size_t moves_of(const std::string& id) {
        auto sent = commands_of(id);
        return static_cast<std::size_t>(std::count_if(
            sent.begin(), sent.end(), [](const std::string& c) { return c.starts_with("M "); }));
    }
};

// A second connection to the job store's file, as another program on the same disk.
class filler {
  public:
    explicit filler(const std::string& path) {
        EXPECT_EQ(sqlite3_open(path.c_str(), &db_), SQLITE_OK);
        sqlite3_busy_timeout(db_, 5000);
    }
    ~filler() { sqlite3_close(db_); }
    filler(const filler&) = delete;
    filler& operator=(const filler&) = delete;

    void exec(const char* sql) {
        char* error = nullptr;
        EXPECT_EQ(sqlite3_exec(db_, sql, nullptr, nullptr, &error), SQLITE_OK) << sql << ": " << error;
        sqlite3_free(error);
    }

  private:
    sqlite3* db_ = nullptr;
};

// The store never fills silently: the manager reads its fill after writes (store_fill_ratio, the
// gw_job_store_fill_ratio metric; the log warns above 80 %).
TEST_F(manager_storage_failure_test, the_fill_of_the_store_is_known_before_it_is_full) {
    storage_max_size_mb_ = 1;
    store_fill_check_ = 0ms;  // every write
    add_sim("sim1", "full", 50);
    start();
    auto first = submit("sim1", job_type::array, next_row(2));
    ASSERT_TRUE(first) << first.error().message;
    ASSERT_TRUE(wait_until([&] { return manager_->store_fill_ratio().has_value(); }));
    const double empty = *manager_->store_fill_ratio();
    EXPECT_GT(empty, 0.0);
    EXPECT_LT(empty, 0.5);
    // Another program takes the file to about 85 % of the 1 MB (room left for the writes below); the
    // next write shows it.
    {
        filler other(database());
        const auto blob_kib = static_cast<int>((0.85 - empty) * 1024);
        other.exec(("CREATE TABLE filler (b BLOB); INSERT INTO filler VALUES (zeroblob(" +
                    std::to_string(blob_kib) + " * 1024))")
                       .c_str());
    }
    ASSERT_TRUE(submit("sim1", job_type::array, next_row(2)));
    ASSERT_TRUE(wait_until([&] { return manager_->store_fill_ratio().value_or(0) >= 0.8; }))
        << "fill " << manager_->store_fill_ratio().value_or(-1);
    {
        filler other(database());
        other.exec("DROP TABLE filler");  // free pages, used again before the file grows
    }
    ASSERT_TRUE(submit("sim1", job_type::array, next_row(2)));
    EXPECT_TRUE(wait_until([&] { return manager_->store_fill_ratio().value_or(1) < 0.5; }))
        << "fill " << manager_->store_fill_ratio().value_or(-1);
}

TEST_F(manager_storage_failure_test, a_store_that_fills_up_pauses_the_running_job_until_it_has_room) {
    constexpr std::size_t wells = 24;
    storage_max_size_mb_ = 1;
    add_sim("sim1", "full", 50);
    start();
    const auto id = run_row_to_first_well(wells);
    ASSERT_FALSE(id.empty());

    // Another program fills the file beyond the gateway's 1 MB: every new page the gateway needs is
    // refused ("database or disk is full"); its steps fill the pages it has first.
    {
        filler other(database());
        other.exec("CREATE TABLE filler (b BLOB); INSERT INTO filler VALUES (zeroblob(2 * 1024 * 1024))");
    }
    bool paused = false;
    while (!paused && steps_done(id) < wells - 1)
        paused = step_once(id);
    ASSERT_TRUE(paused) << "the job ran every well on a full store";
    auto j = job(id);
    ASSERT_TRUE(j);
    EXPECT_TRUE(j->reason.starts_with("storage unavailable: ")) << j->reason;
    EXPECT_NE(j->reason.find("full"), std::string::npos) << j->reason;
    const auto done = j->progress.steps_done;
    EXPECT_EQ(moves_of(id), done);
    expect_silence(id);
    // Still full: the resume is refused and the job stays paused; the service answers.
    auto refused = resume(id);
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, kind::storage_unavailable);
    EXPECT_NE(refused.error().message.find("full"), std::string::npos) << refused.error().message;
    EXPECT_EQ(job(id)->state, job_state::paused);
    EXPECT_TRUE(manager_->list(job_filter{}));
    EXPECT_TRUE(submit("sim1", job_type::array, next_row(3), std::nullopt, std::nullopt, true));

    // Room again; the resume continues after the last completed step.
    {
        filler other(database());
        other.exec("DROP TABLE filler; VACUUM");
    }
    ASSERT_TRUE(resume(id));
    EXPECT_EQ(steps_done(id), done);
    finish(id, wells);
    EXPECT_EQ(moves_of(id), wells) << "a well was moved to twice, or skipped";
    EXPECT_EQ(stored_steps(id), all_steps(wells));
    EXPECT_EQ(stored_states(id),
              (std::vector<std::string>{"queued", "running", "paused", "queued", "running", "succeeded"}));
    // The pause and its reason are stored with the rest.
    for (const auto& e : stored_events(id)) {
        if (e.value("state", "") == "paused") {
            EXPECT_TRUE(e.value("reason", "").starts_with("storage unavailable: ")) << e.dump();
        }
    }
}

class manager_failing_writes_test : public manager_storage_failure_test {
  protected:
    // Before the fixture opens the store: its connection goes through the fake. Destroyed after the
    // fixture's TearDown has closed the store.
    gw::test::failing_vfs vfs_;
};

TEST_F(manager_failing_writes_test, a_read_only_store_refuses_submissions_and_the_service_goes_on) {
    add_sim("sim1", "full", 50);
    start();
    auto before = submit("sim1", job_type::array, next_row(2));
    ASSERT_TRUE(before) << before.error().message;
    ASSERT_TRUE(cancel(before->job.id));

    vfs_.fail_writes(SQLITE_IOERR_WRITE);  // what a file system remounted read-only gives (EROFS)
    auto refused = submit("sim1", job_type::array, next_row(3));
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, kind::storage_unavailable);
    EXPECT_NE(refused.error().message.find("jobs.sqlite3"), std::string::npos) << refused.error().message;
    EXPECT_GT(vfs_.writes_refused(), 0);
    // Reads, dry runs and the other jobs' history still work; nothing of the refused job was queued.
    auto page = manager_->list(job_filter{});
    ASSERT_TRUE(page) << page.error().message;
    ASSERT_EQ(page->jobs.size(), 1u);
    EXPECT_EQ(page->jobs.front().id, before->job.id);
    EXPECT_EQ(job(before->job.id)->state, job_state::cancelled);
    EXPECT_TRUE(submit("sim1", job_type::array, next_row(3), std::nullopt, std::nullopt, true));

    vfs_.fail_writes(0);
    auto after = submit("sim1", job_type::array, next_row(2));
    ASSERT_TRUE(after) << after.error().message;
    ASSERT_TRUE(next(after->job.id));
    ASSERT_TRUE(wait_state(after->job.id, job_state::succeeded));
}

TEST_F(manager_failing_writes_test, a_running_job_pauses_when_writes_fail_and_resumes_when_they_work) {
    constexpr std::size_t wells = 5;
    add_sim("sim1", "full", 50);
    start();
    const auto id = run_row_to_first_well(wells);
    ASSERT_FALSE(id.empty());

    vfs_.fail_writes(SQLITE_READONLY);
    ASSERT_TRUE(step_once(id)) << "the job went on although its step could not be stored";
    auto j = job(id);
    EXPECT_EQ(j->progress.steps_done, 2u);
    EXPECT_EQ(j->reason.rfind("storage unavailable: ", 0), 0u) << j->reason;
    EXPECT_EQ(j->progress.waiting_for, job_wait::storage);
    EXPECT_EQ(moves_of(id), 2u);
    expect_silence(id);
    auto refused = resume(id);
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, kind::storage_unavailable);
    // The store has the first step only; the second and the pause wait in memory.
    EXPECT_EQ(stored_steps(id), all_steps(1));

    vfs_.fail_writes(0);
    // The retry stores the history: the job waits for a client's resume now, and says so on its topic.
    ASSERT_TRUE(wait_until([&] { return !job(id)->progress.waiting_for; }, 10s))
        << "still waits for the store";
    EXPECT_EQ(job(id)->state, job_state::paused);
    EXPECT_EQ(stored_steps(id), all_steps(2));
    ASSERT_TRUE(wait_until([&] {
        const auto events = sink_->of(id);
        return !events.empty() && events.back().value("state", "") == "paused" &&
               events.back()["waiting_for"].is_null();
    })) << "no event for the end of the wait";
    ASSERT_TRUE(resume(id));
    finish(id, wells);
    EXPECT_EQ(moves_of(id), wells);
    EXPECT_EQ(stored_steps(id), all_steps(wells));
    EXPECT_EQ(stored_states(id),
              (std::vector<std::string>{"queued", "running", "paused", "queued", "running", "succeeded"}));
}

// The writes that wait in memory are bounded: beyond the bound the oldest is given up; the job's state
// and progress still reach the store with the later writes.
TEST_F(manager_failing_writes_test, the_unstored_writes_are_bounded_and_the_oldest_is_given_up) {
    max_unstored_writes_ = 2;
    add_sim("sim1", "full", 50);
    start();
    const auto id = run_row_to_first_well(4);
    ASSERT_FALSE(id.empty());

    vfs_.fail_writes(SQLITE_READONLY);
    ASSERT_TRUE(step_once(id));  // kept: the second well's step, then the pause
    ASSERT_TRUE(cancel(id));     // the cancel's state is the third write: the step is given up
    ASSERT_TRUE(wait_state(id, job_state::cancelled));
    vfs_.fail_writes(0);
    ASSERT_TRUE(wait_until([&] {
        const auto states = stored_states(id);
        return !states.empty() && states.back() == "cancelled";
    }));
    EXPECT_EQ(stored_states(id), (std::vector<std::string>{"queued", "running", "paused", "cancelled"}));
    EXPECT_EQ(stored_steps(id), all_steps(1)) << "the second well's step event was kept beyond the bound";
    const auto j = job(id);
    EXPECT_EQ(j->state, job_state::cancelled);
    EXPECT_EQ(j->progress.steps_done, 2u);
}

TEST_F(manager_failing_writes_test, an_end_the_store_refused_is_stored_once_it_can_be_and_survives_a_crash) {
    constexpr std::size_t wells = 3;
    add_sim("sim1", "full", 50);
    start();
    const auto id = run_row_to_first_well(wells);
    ASSERT_FALSE(id.empty());
    ASSERT_FALSE(step_once(id));
    ASSERT_EQ(steps_done(id), wells - 1);

    // The last step and the job's end cannot be stored: there is no checkpoint left to pause at, so it
    // succeeds in memory, and the store has it as running.
    vfs_.fail_writes(SQLITE_FULL);
    ASSERT_TRUE(next(id));
    ASSERT_TRUE(wait_state(id, job_state::succeeded));
    auto ended = resume(id);  // ended, although the store still says running
    ASSERT_FALSE(ended);
    EXPECT_EQ(ended.error().kind, kind::invalid_state);
    auto cancelled = cancel(id);
    ASSERT_FALSE(cancelled);
    EXPECT_EQ(cancelled.error().kind, kind::invalid_state);
    EXPECT_EQ(stored_states(id), (std::vector<std::string>{"queued", "running"}));

    // Writes work again: the manager catches up by itself (it retries), in order.
    vfs_.fail_writes(0);
    ASSERT_TRUE(wait_until([&] { return stored_states(id).size() == 3; }, 10s));
    EXPECT_EQ(stored_states(id), (std::vector<std::string>{"queued", "running", "succeeded"}));
    EXPECT_EQ(stored_steps(id), all_steps(wells));
    // A crash now: the job is still succeeded, not interrupted, and nothing is resumed.
    restart_manager();
    auto j = job(id);
    ASSERT_TRUE(j);
    EXPECT_EQ(j->state, job_state::succeeded);
    EXPECT_EQ(j->progress.steps_done, wells);
}

}  // namespace
}  // namespace gw::jobs::test
