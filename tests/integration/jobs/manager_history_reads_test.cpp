// The job manager's reads of the history for an I/O thread (async_get, async_list, async_events): run on
// its history reader thread, they answer what the synchronous reads answer, errors included.
#include "tests/integration/jobs/manager_fixture.hpp"

namespace gw::jobs::test {
namespace {

using kind = operation_error_kind;

class manager_history_reads_test : public manager_fixture {};

TEST_F(manager_history_reads_test, the_asynchronous_reads_answer_what_the_store_holds) {
    add_sim("sim3", "planar");
    start();
    auto submitted = submit("sim3", job_type::planar_correction, {{"action", "clear"}});
    ASSERT_TRUE(submitted) << submitted.error().message;
    const auto id = submitted->job.id;
    ASSERT_TRUE(wait_state(id, job_state::succeeded));

    const auto got = await(call<job_record>([&](auto h) { manager_->async_get(id, std::move(h)); }));
    ASSERT_TRUE(got) << got.error().message;
    EXPECT_EQ(got->id, id);
    EXPECT_EQ(got->state, job_state::succeeded);

    job_filter all;
    const auto page = await(call<job_page>([&](auto h) { manager_->async_list(all, std::move(h)); }));
    ASSERT_TRUE(page) << page.error().message;
    ASSERT_EQ(page->jobs.size(), 1u);
    EXPECT_EQ(page->jobs[0].id, id);

    const auto events = await(
        call<std::vector<nlohmann::json>>([&](auto h) { manager_->async_events(id, 1000, std::move(h)); }));
    ASSERT_TRUE(events) << events.error().message;
    const auto stored = manager_->events(id, 1000);
    ASSERT_TRUE(stored);
    EXPECT_EQ(*events, *stored);
    EXPECT_GE(events->size(), 2u);  // at least queued and succeeded

    const auto unknown =
        await(call<job_record>([&](auto h) { manager_->async_get("j-nope", std::move(h)); }));
    ASSERT_FALSE(unknown);
    EXPECT_EQ(unknown.error().kind, kind::unknown_job);
    const auto no_events = await(call<std::vector<nlohmann::json>>(
        [&](auto h) { manager_->async_events("j-nope", 10, std::move(h)); }));
    ASSERT_FALSE(no_events);
    EXPECT_EQ(no_events.error().kind, kind::unknown_job);
}

}  // namespace
}  // namespace gw::jobs::test
