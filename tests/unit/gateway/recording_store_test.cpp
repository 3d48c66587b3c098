// The recordings store on a real SQLite file: records, rows appended with their counters, pages, and
// what survives closing the file.
#include "gateway/recordings/recording_store.hpp"

#include <filesystem>
#include <limits>
#include <sqlite3.h>
#include <unistd.h>

#include <gtest/gtest.h>

namespace gw::recordings {
namespace {

namespace fs = std::filesystem;

class recording_store_test : public ::testing::Test {
  protected:
    void SetUp() override {
        std::string tmpl = (fs::temp_directory_path() / "gw-recording-store-XXXXXX").string();
        ASSERT_NE(mkdtemp(tmpl.data()), nullptr);
        dir_ = tmpl;
        store_ = open();
    }
    void TearDown() override {
        store_.reset();
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    std::unique_ptr<recording_store> open() {
        auto s = recording_store::open(dir_);
        EXPECT_TRUE(s) << (s ? "" : s.error());
        return s ? std::move(*s) : nullptr;
    }
    static recording_record record(std::string id, std::string controller, std::int64_t started_ms) {
        recording_record r;
        r.id = std::move(id);
        r.controller = std::move(controller);
        r.name = "n";
        r.started_ms = started_ms;
        r.previous_in_mode = 0;
        r.max_frames = 10;
        r.metadata = {{"well", "C7"}};
        return r;
    }
    static recorded_frame frame(std::uint64_t index, std::int32_t x, std::optional<double> x_um) {
        recorded_frame f;
        f.index = index;
        f.time_us = 1'700'000'000'000'000 + static_cast<std::int64_t>(index);
        f.counts = {x, std::numeric_limits<std::int32_t>::min()};
        f.um = {x_um, std::nullopt};
        return f;
    }

    std::string dir_;
    std::unique_ptr<recording_store> store_;
};

TEST_F(recording_store_test, rows_come_back_as_they_went_in_with_the_counters) {
    auto r = record("r-1", "sim1", 1000);
    ASSERT_TRUE(store_->create(r));
    std::vector<recorded_frame> rows{frame(0, 12345, 1234.5), frame(1, -7, std::nullopt)};
    recorded_frame marker;
    marker.index = 2;
    marker.loss = loss_kind::disconnected;
    rows.push_back(marker);
    rows.push_back(frame(2, 0, 0.0));
    r.frames = 3;
    r.losses = 1;
    r.axes = "XY";
    ASSERT_TRUE(store_->append(r, rows));

    store_ = open();  // what is on disk, not in memory
    auto got = store_->get("r-1");
    ASSERT_TRUE(got && *got);
    EXPECT_EQ((*got)->frames, 3u);
    EXPECT_EQ((*got)->losses, 1u);
    EXPECT_EQ((*got)->axes, "XY");
    EXPECT_EQ((*got)->metadata["well"], "C7");
    EXPECT_EQ((*got)->max_frames, 10u);
    EXPECT_EQ((*got)->previous_in_mode, 0);

    auto page = store_->rows("r-1", 0, 100);
    ASSERT_TRUE(page);
    ASSERT_EQ(page->rows.size(), 4u);
    EXPECT_FALSE(page->next);
    EXPECT_EQ(page->rows[0].counts,
              (std::vector<std::int32_t>{12345, std::numeric_limits<std::int32_t>::min()}));
    EXPECT_EQ(page->rows[0].um[0], 1234.5);
    EXPECT_EQ(page->rows[0].um[1], std::nullopt);
    EXPECT_EQ(page->rows[1].counts[0], -7);
    EXPECT_EQ(page->rows[1].um[0], std::nullopt);
    EXPECT_EQ(page->rows[2].loss, loss_kind::disconnected);
    EXPECT_EQ(page->rows[2].index, 2u);
    EXPECT_EQ(page->rows[3].index, 2u);
    EXPECT_EQ(page->rows[3].time_us, rows[3].time_us);
}

TEST_F(recording_store_test, pages_follow_each_other_without_gaps_or_repeats) {
    auto r = record("r-1", "sim1", 1000);
    ASSERT_TRUE(store_->create(r));
    std::vector<recorded_frame> rows;
    for (std::uint64_t i = 0; i < 25; ++i)
        rows.push_back(frame(i, static_cast<std::int32_t>(i), std::nullopt));
    r.frames = rows.size();
    ASSERT_TRUE(store_->append(r, rows));
    std::vector<std::uint64_t> seen;
    std::int64_t from = 0;
    for (;;) {
        auto page = store_->rows("r-1", from, 10);
        ASSERT_TRUE(page);
        for (const auto& f : page->rows)
            seen.push_back(f.index);
        if (!page->next) break;
        from = *page->next;
    }
    ASSERT_EQ(seen.size(), 25u);
    for (std::size_t i = 0; i < seen.size(); ++i)
        EXPECT_EQ(seen[i], i);
}

TEST_F(recording_store_test, lists_newest_first_by_controller_and_state_and_removes_with_rows) {
    for (auto [id, controller, at] :
         {std::tuple{"r-1", "sim1", 1000}, {"r-2", "sim2", 2000}, {"r-3", "sim1", 3000}})
        ASSERT_TRUE(store_->create(record(id, controller, at)));
    auto stopped = record("r-3", "sim1", 3000);
    stopped.state = recording_state::stopped;
    stopped.stopped_ms = 4000;
    ASSERT_TRUE(store_->update(stopped));

    auto all = store_->list({});
    ASSERT_TRUE(all);
    ASSERT_EQ(all->size(), 3u);
    EXPECT_EQ((*all)[0].id, "r-3");
    EXPECT_EQ((*all)[2].id, "r-1");
    recording_filter of_sim1;
    of_sim1.controller = "sim1";
    auto sim1 = store_->list(of_sim1);
    ASSERT_EQ(sim1->size(), 2u);
    recording_filter recording_now;
    recording_now.state = recording_state::recording;
    auto recording = store_->list(recording_now);
    ASSERT_EQ(recording->size(), 2u);
    recording_filter one;
    one.limit = 1;
    EXPECT_EQ(store_->list(one)->size(), 1u);
    recording_filter between;
    between.since_ms = 2000;
    between.until_ms = 3000;
    auto in_time = store_->list(between);
    ASSERT_EQ(in_time->size(), 1u);  // since is inclusive, until is not
    EXPECT_EQ((*in_time)[0].id, "r-2");

    auto r1 = record("r-1", "sim1", 1000);
    r1.frames = 1;
    ASSERT_TRUE(store_->append(r1, std::vector<recorded_frame>{frame(0, 1, std::nullopt)}));
    EXPECT_TRUE(*store_->remove("r-1"));
    EXPECT_FALSE(*store_->remove("r-1"));
    EXPECT_FALSE(*store_->get("r-1"));
    EXPECT_TRUE(store_->rows("r-1", 0, 10)->rows.empty());
}

TEST_F(recording_store_test, a_loss_value_no_writer_makes_reads_as_a_loss) {
    auto r = record("r-1", "sim1", 1000);
    ASSERT_TRUE(store_->create(r));
    r.frames = 1;
    ASSERT_TRUE(store_->append(r, std::vector<recorded_frame>{frame(0, 1, std::nullopt)}));
    store_.reset();
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((fs::path(dir_) / "recordings.sqlite3").c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "UPDATE frames SET loss = 77", nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
    store_ = open();
    auto page = store_->rows("r-1", 0, 10);
    ASSERT_TRUE(page);
    ASSERT_EQ(page->rows.size(), 1u);
    EXPECT_EQ(page->rows[0].loss, loss_kind::garbled);
}

TEST_F(recording_store_test, several_recordings_go_in_one_transaction_or_none_does) {
    for (const char* id : {"r-1", "r-2"})
        ASSERT_TRUE(store_->create(record(id, "sim1", 1000)));
    auto r1 = record("r-1", "sim1", 1000);
    auto r2 = record("r-2", "sim1", 1000);
    r1.frames = 2;
    r2.frames = 1;
    std::vector<row_batch> both{{r1, {frame(0, 10, 1.0), frame(1, 11, 1.1)}}, {r2, {frame(0, 20, 2.0)}}};
    ASSERT_TRUE(store_->append_all(both));
    EXPECT_EQ(store_->rows("r-1", 0, 10)->rows.size(), 2u);
    EXPECT_EQ(store_->rows("r-2", 0, 10)->rows.at(0).counts.at(0), 20);
    EXPECT_EQ((*store_->get("r-2"))->frames, 1u);

    // A batch of a recording the file does not have: nothing of the transaction stays.
    auto more = r1;
    more.frames = 3;
    auto unknown = record("r-9", "sim1", 1000);
    unknown.frames = 1;
    std::vector<row_batch> bad{{more, {frame(2, 12, 1.2)}}, {unknown, {frame(0, 1, 0.1)}}};
    EXPECT_FALSE(store_->append_all(bad));
    EXPECT_EQ(store_->rows("r-1", 0, 10)->rows.size(), 2u);
    EXPECT_EQ((*store_->get("r-1"))->frames, 2u);
}

TEST_F(recording_store_test, a_file_of_another_layout_is_replaced) {
    store_.reset();
    const auto path = fs::path(dir_) / "recordings.sqlite3";
    fs::remove(path);
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db,
                           "CREATE TABLE frames (row INTEGER PRIMARY KEY, recording TEXT);"
                           "CREATE TABLE recordings (id TEXT PRIMARY KEY);",
                           nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
    store_ = open();
    ASSERT_TRUE(store_);
    ASSERT_TRUE(store_->create(record("r-1", "sim1", 1000)));
    auto r = record("r-1", "sim1", 1000);
    r.frames = 1;
    EXPECT_TRUE(store_->append(r, std::vector<recorded_frame>{frame(0, 5, 0.5)}));
    store_ = open();  // the new layout stays
    EXPECT_EQ(store_->rows("r-1", 0, 10)->rows.size(), 1u);
}

TEST_F(recording_store_test, a_file_of_the_second_layout_keeps_its_recordings_and_gains_their_job) {
    ASSERT_TRUE(store_->create(record("r-1", "sim1", 1000)));
    auto r = record("r-1", "sim1", 1000);
    r.frames = 1;
    ASSERT_TRUE(store_->append(r, std::vector<recorded_frame>{frame(0, 5, 0.5)}));
    store_.reset();
    // Back to the second layout: the recordings table without its job column.
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((fs::path(dir_) / "recordings.sqlite3").c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db,
                           "DROP INDEX recordings_job; ALTER TABLE recordings DROP COLUMN job; "
                           "PRAGMA user_version = 2;",
                           nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);

    store_ = open();
    ASSERT_TRUE(store_);
    auto kept = store_->get("r-1");
    ASSERT_TRUE(kept && *kept);
    EXPECT_EQ((*kept)->frames, 1u);
    EXPECT_EQ((*kept)->job, std::nullopt);
    EXPECT_EQ(store_->rows("r-1", 0, 10)->rows.size(), 1u);
    auto by_job = record("r-2", "sim1", 2000);
    by_job.job = "j-7";
    ASSERT_TRUE(store_->create(by_job));
    recording_filter f;
    f.job = "j-7";
    auto listed = store_->list(f);
    ASSERT_TRUE(listed);
    ASSERT_EQ(listed->size(), 1u);
    EXPECT_EQ((*listed)[0].id, "r-2");
    EXPECT_EQ((*listed)[0].job, "j-7");
}

}  // namespace
}  // namespace gw::recordings
