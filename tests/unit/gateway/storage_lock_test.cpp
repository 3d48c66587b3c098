// storage_lock on real files: one holder at a time, released when the holder goes away.
#include "gateway/storage/storage_lock.hpp"

#include <filesystem>
#include <string>
#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

namespace gw {
namespace {

class storage_lock_test : public ::testing::Test {
  protected:
    void TearDown() override { std::filesystem::remove_all(dir_); }
    std::string dir_ = "/tmp/gw-storage-lock-" + std::to_string(::getpid()) + "/store";
};

TEST_F(storage_lock_test, a_second_holder_is_refused_until_the_first_lets_go) {
    auto first = storage_lock::acquire(dir_);
    ASSERT_TRUE(first) << first.error().message;
    EXPECT_TRUE(std::filesystem::exists(dir_ + "/lock"));

    auto second = storage_lock::acquire(dir_);
    ASSERT_FALSE(second);
    EXPECT_EQ(second.error().kind, operation_error_kind::storage_unavailable);
    EXPECT_NE(second.error().message.find("another asi-gateway"), std::string::npos)
        << second.error().message;
    EXPECT_NE(second.error().message.find(dir_), std::string::npos) << second.error().message;

    { auto moved = std::move(*first); }  // the holder (moved-to) is destroyed here
    auto third = storage_lock::acquire(dir_);
    EXPECT_TRUE(third) << third.error().message;
}

TEST_F(storage_lock_test, an_unusable_directory_is_an_error) {
    auto lock = storage_lock::acquire("/proc/asi-gateway-cannot-be-here");
    ASSERT_FALSE(lock);
    EXPECT_EQ(lock.error().kind, operation_error_kind::storage_unavailable);
    EXPECT_NE(lock.error().message.find("/proc/asi-gateway-cannot-be-here/lock"), std::string::npos)
        << lock.error().message;
}

}  // namespace
}  // namespace gw
