// gcode_file_store on real files in a temporary directory: save/list/get/remove, the size cap, unknown
// ids (path tricks included), and a directory the process may not write.
#include "gateway/storage/gcode_files.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

namespace gw {
namespace {

namespace fs = std::filesystem;

class gcode_files_test : public ::testing::Test {
  protected:
    void SetUp() override { fs::remove_all(root_); }
    void TearDown() override {
        std::error_code ignored;
        fs::permissions(root_, fs::perms::owner_all, ignored);
        fs::remove_all(root_);
    }
    gcode_file_store store(std::size_t max_bytes = 1024 * 1024) {
        return gcode_file_store({.directory = root_ / "gcode", .max_file_bytes = max_bytes});
    }
    static std::string read(const fs::path& p) {
        std::ifstream in(p, std::ios::binary);
        std::ostringstream s;
        s << in.rdbuf();
        return s.str();
    }

    fs::path root_ = fs::temp_directory_path() / ("gw-gcode-files-" + std::to_string(::getpid()));
};

TEST(gcode_directory, is_the_gcode_folder_of_the_storage_path) {
    EXPECT_EQ(gcode_directory("/var/lib/asi-gateway"), std::filesystem::path("/var/lib/asi-gateway/gcode"));
    EXPECT_TRUE(gcode_directory("").empty());
}

TEST_F(gcode_files_test, a_saved_program_is_listed_read_back_and_deleted) {
    auto s = store();
    std::istringstream program("G21 G90\nG01 X1 F60\nM03\nG01 Y1\nM05");  // no final newline
    auto saved = s.save(program, "square.ngc");
    ASSERT_TRUE(saved) << saved.error().message;
    EXPECT_TRUE(is_gcode_file_id(saved->id)) << saved->id;
    EXPECT_EQ(saved->name, "square.ngc");
    EXPECT_EQ(saved->bytes, program.str().size());
    EXPECT_EQ(saved->lines, 5u);
    EXPECT_GT(saved->created_ms, 1'700'000'000'000);

    auto path = s.path_of(saved->id);
    ASSERT_TRUE(path) << path.error().message;
    EXPECT_EQ(read(*path), program.str());
    auto got = s.get(saved->id);
    ASSERT_TRUE(got);
    EXPECT_EQ(*got, *saved);

    std::istringstream second("G00 X2\n");
    auto later = s.save(second, "");
    ASSERT_TRUE(later);
    EXPECT_EQ(later->name, "untitled");
    EXPECT_EQ(later->lines, 1u);
    auto all = s.list();
    ASSERT_TRUE(all);
    ASSERT_EQ(all->size(), 2u);
    EXPECT_EQ((*all)[0].id, later->id);  // newest first
    EXPECT_EQ((*all)[1].id, saved->id);

    ASSERT_TRUE(s.remove(saved->id));
    EXPECT_FALSE(fs::exists(*path));
    auto gone = s.get(saved->id);
    ASSERT_FALSE(gone);
    EXPECT_EQ(gone.error().kind, operation_error_kind::unknown_file);
    EXPECT_EQ(s.list()->size(), 1u);
    auto again = s.remove(saved->id);
    ASSERT_FALSE(again);
    EXPECT_EQ(again.error().kind, operation_error_kind::unknown_file);
}

TEST_F(gcode_files_test, an_empty_store_lists_nothing_without_creating_its_directory) {
    auto s = store();
    auto all = s.list();
    ASSERT_TRUE(all);
    EXPECT_TRUE(all->empty());
    EXPECT_FALSE(fs::exists(root_ / "gcode"));
}

TEST_F(gcode_files_test, a_program_over_the_cap_is_refused_and_leaves_nothing) {
    auto s = store(100 * 1024);
    std::string big(100 * 1024 + 1, 'X');
    std::istringstream in(big);
    auto saved = s.save(in, "big");
    ASSERT_FALSE(saved);
    EXPECT_EQ(saved.error().kind, operation_error_kind::invalid_value);
    EXPECT_NE(saved.error().message.find("102400"), std::string::npos) << saved.error().message;
    EXPECT_TRUE(fs::is_empty(root_ / "gcode"));  // no temporary left behind

    std::istringstream exact(std::string(100 * 1024, 'X'));
    EXPECT_TRUE(s.save(exact, "exact"));
}

TEST_F(gcode_files_test, an_upload_streamed_in_pieces_is_stored_whole) {
    auto s = store();
    auto upload = s.begin_upload();
    EXPECT_FALSE(fs::exists(root_ / "gcode"));  // nothing on disk before the first bytes
    for (std::string_view piece : {"G21 G90\nG01 X", "1 F60\n", "", "M03\nG01 Y1"})
        ASSERT_TRUE(upload.append(piece));
    EXPECT_EQ(upload.bytes(), 29u);
    auto saved = s.commit(std::move(upload), "pieces.ngc");
    ASSERT_TRUE(saved) << saved.error().message;
    EXPECT_EQ(saved->bytes, 29u);
    EXPECT_EQ(saved->lines, 4u);  // three newlines and a last line without one
    EXPECT_EQ(read(*s.path_of(saved->id)), "G21 G90\nG01 X1 F60\nM03\nG01 Y1");
    EXPECT_EQ(*s.get(saved->id), *saved);
    for (const auto& e : fs::directory_iterator(root_ / "gcode"))  // no temporary left behind
        EXPECT_NE(e.path().extension(), ".tmp") << e.path();
}

TEST_F(gcode_files_test, an_upload_read_in_place_and_dropped_leaves_nothing) {
    auto s = store();
    {
        auto upload = s.begin_upload();
        ASSERT_TRUE(upload.append("G00 X1\n"));
        auto file = upload.contents();
        ASSERT_TRUE(file) << file.error().message;
        EXPECT_EQ(read(*file), "G00 X1\n");  // a plan reads it where it is
    }
    EXPECT_TRUE(fs::is_empty(root_ / "gcode"));
    EXPECT_TRUE(s.list()->empty());
    auto empty = s.begin_upload();
    auto file = empty.contents();  // an empty body is an empty program
    ASSERT_TRUE(file);
    EXPECT_EQ(read(*file), "");
}

TEST_F(gcode_files_test, temporaries_left_by_a_crash_are_removed_and_programs_kept) {
    auto s = store();
    EXPECT_EQ(s.remove_stale_temporaries(), 0u);  // no directory yet: nothing to do
    std::istringstream program("G00 X1\n");
    auto kept = s.save(program, "kept");
    ASSERT_TRUE(kept);
    auto cut_short = s.begin_upload();
    ASSERT_TRUE(cut_short.append("G00 X2\n"));
    std::ofstream(root_ / "gcode" / ".g-01JD4ZQ3M0Z8B1K2W6R9T5X7YA.json.tmp") << "{";
    EXPECT_EQ(s.remove_stale_temporaries(), 2u);
    EXPECT_EQ(s.list()->size(), 1u);
    EXPECT_TRUE(s.get(kept->id));
    for (const auto& e : fs::directory_iterator(root_ / "gcode"))
        EXPECT_NE(e.path().extension(), ".tmp") << e.path();
}

TEST_F(gcode_files_test, an_upload_over_the_cap_fails_at_the_bytes_that_cross_it) {
    auto s = store(1000);
    auto upload = s.begin_upload();
    ASSERT_TRUE(upload.append(std::string(600, 'X')));
    auto over = upload.append(std::string(401, 'X'));
    ASSERT_FALSE(over);
    EXPECT_EQ(over.error().kind, operation_error_kind::invalid_value);
    EXPECT_EQ(over.error().field, "body");
    EXPECT_FALSE(upload.append("X"));  // nothing more after an error
    auto saved = s.commit(std::move(upload), "x");
    EXPECT_FALSE(saved);
    EXPECT_TRUE(fs::is_empty(root_ / "gcode"));
}

TEST_F(gcode_files_test, a_bad_name_is_refused_before_any_byte_is_stored) {
    EXPECT_TRUE(check_gcode_file_name("part.ngc"));
    EXPECT_TRUE(check_gcode_file_name(""));
    auto bad = check_gcode_file_name("a\tb");
    ASSERT_FALSE(bad);
    EXPECT_EQ(bad.error().field, "name");
    EXPECT_FALSE(check_gcode_file_name(std::string(256, 'n')));
    auto s = store();
    auto upload = s.begin_upload();
    ASSERT_TRUE(upload.append("G00 X1\n"));
    auto saved = s.commit(std::move(upload), "a\nb");
    ASSERT_FALSE(saved);
    EXPECT_EQ(saved.error().field, "name");
    EXPECT_TRUE(fs::is_empty(root_ / "gcode"));
}

TEST_F(gcode_files_test, unknown_and_malformed_ids_are_unknown_file) {
    auto s = store();
    std::istringstream program("G00 X1\n");
    ASSERT_TRUE(s.save(program, "p"));
    for (std::string id : {"g-01JD4ZQ3M0Z8B1K2W6R9T5X7YA", "nope", "", "g-../../etc/passwd",
                           "j-01JD4ZQ3M0Z8B1K2W6R9T5X7YA", "g-01jd4zq3m0z8b1k2w6r9t5x7ya"}) {
        auto got = s.path_of(id);
        ASSERT_FALSE(got) << id;
        EXPECT_EQ(got.error().kind, operation_error_kind::unknown_file) << id;
        EXPECT_NE(got.error().message.find(id), std::string::npos);
    }
}

TEST_F(gcode_files_test, a_name_with_control_characters_is_refused) {
    auto s = store();
    std::istringstream program("G00 X1\n");
    auto saved = s.save(program, "a\nb");
    ASSERT_FALSE(saved);
    EXPECT_EQ(saved.error().kind, operation_error_kind::invalid_value);
    EXPECT_EQ(saved.error().field, "name");
}

TEST_F(gcode_files_test, a_directory_that_cannot_be_created_is_storage_unavailable) {
    gcode_file_store s({.directory = "/proc/asi-gateway-cannot-be-here/gcode"});
    std::istringstream program("G00 X1\n");
    auto saved = s.save(program, "p");
    ASSERT_FALSE(saved);
    EXPECT_EQ(saved.error().kind, operation_error_kind::storage_unavailable);
    EXPECT_NE(saved.error().message.find("/proc/asi-gateway-cannot-be-here"), std::string::npos);
}

// A read-only store directory. Root ignores modes, so a child process drops to "nobody" first; its
// verdict comes back in the exit code: 0 storage_unavailable, 1 saved, 2 cannot drop, 3 other error.
TEST_F(gcode_files_test, a_read_only_directory_is_storage_unavailable) {
    auto s = store();
    std::istringstream first("G00 X1\n");
    auto saved = s.save(first, "kept");
    ASSERT_TRUE(saved);
    using p = fs::perms;
    fs::permissions(root_, p::owner_all | p::group_read | p::group_exec | p::others_read | p::others_exec);
    fs::permissions(root_ / "gcode", p::owner_read | p::owner_exec | p::group_read | p::group_exec |
                                         p::others_read | p::others_exec);
    pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        if (geteuid() == 0 && (setgid(65534) != 0 || setuid(65534) != 0)) _exit(2);
        std::istringstream program("G00 X2\n");
        auto r = s.save(program, "p");
        if (r) _exit(1);
        _exit(r.error().kind == operation_error_kind::storage_unavailable ? 0 : 3);
    }
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFEXITED(status));
    if (WEXITSTATUS(status) == 2) GTEST_SKIP() << "cannot drop to nobody";
    EXPECT_EQ(WEXITSTATUS(status), 0);
    fs::permissions(root_ / "gcode", p::owner_all);
    auto all = s.list();  // the earlier program is intact
    ASSERT_TRUE(all);
    ASSERT_EQ(all->size(), 1u);
    EXPECT_EQ((*all)[0].id, saved->id);
}

TEST_F(gcode_files_test, the_api_json_has_an_rfc3339_creation_time) {
    gcode_file_info info{"g-01JD4ZQ3M0Z8B1K2W6R9T5X7YA", "a.ngc", 12, 2, 1'764'489'600'123};
    auto j = to_json(info);
    EXPECT_EQ(j["created"], "2025-11-30T08:00:00.123Z");
    EXPECT_EQ(j["bytes"], 12);
    EXPECT_EQ(j["lines"], 2);
}

}  // namespace
}  // namespace gw
