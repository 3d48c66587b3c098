#include "gateway/storage/storage_lock.hpp"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fmt/format.h>
#include <sys/file.h>
#include <unistd.h>
#include <utility>

namespace gw {

operation_result<storage_lock> storage_lock::acquire(const std::string& directory) {
    namespace fs = std::filesystem;
    std::error_code ec;
    fs::create_directories(directory, ec);
    const auto path = (fs::path(directory) / "lock").string();
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0)
        return make_error(operation_error_kind::storage_unavailable,
                          fmt::format("cannot open {}: {}", path, std::strerror(errno)));
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
        const int error = errno;
        ::close(fd);
        if (error == EWOULDBLOCK)
            return make_error(operation_error_kind::storage_unavailable,
                              fmt::format("another asi-gateway uses the storage directory {} (it holds {})",
                                          directory, path));
        return make_error(operation_error_kind::storage_unavailable,
                          fmt::format("cannot lock {}: {}", path, std::strerror(error)));
    }
    return storage_lock(fd);
}

storage_lock::storage_lock(storage_lock&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}

storage_lock& storage_lock::operator=(storage_lock&& other) noexcept {
    if (this != &other) {
        if (fd_ >= 0) ::close(fd_);
        fd_ = std::exchange(other.fd_, -1);
    }
    return *this;
}

storage_lock::~storage_lock() {
    if (fd_ >= 0) ::close(fd_);  // closing the descriptor releases the flock
}

}  // namespace gw
