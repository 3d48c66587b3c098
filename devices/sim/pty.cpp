#include "devices/sim/pty.hpp"

#include <cerrno>
#include <fcntl.h>
#include <filesystem>
#include <stdlib.h>
#include <sys/stat.h>
#include <system_error>
#include <termios.h>
#include <unistd.h>

namespace gw::devices::sim {

namespace {
[[noreturn]] void throw_errno(const char* what) {
    throw std::system_error(errno, std::generic_category(), what);
}
}  // namespace

pty_pair open_pty() {
    pty_pair p;
    p.master = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (p.master < 0) throw_errno("posix_openpt");
    if (::grantpt(p.master) != 0 || ::unlockpt(p.master) != 0) {
        const int e = errno;
        close_fd(p.master);
        throw std::system_error(e, std::generic_category(), "grantpt/unlockpt");
    }
    char name[128] = {};
    if (::ptsname_r(p.master, name, sizeof name) != 0) {
        const int e = errno;
        close_fd(p.master);
        throw std::system_error(e, std::generic_category(), "ptsname_r");
    }
    p.slave_path = name;
    p.slave = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (p.slave < 0) {
        const int e = errno;
        close_fd(p.master);
        throw std::system_error(e, std::generic_category(), "open pty slave");
    }
    termios tio{};
    if (::tcgetattr(p.slave, &tio) == 0) {
        ::cfmakeraw(&tio);
        tio.c_cc[VMIN] = 1;
        tio.c_cc[VTIME] = 0;
        ::tcsetattr(p.slave, TCSANOW, &tio);
    }
    const int flags = ::fcntl(p.master, F_GETFL);
    ::fcntl(p.master, F_SETFL, flags | O_NONBLOCK);
    return p;
}

void close_fd(int& fd) {
    if (fd >= 0) ::close(fd);
    fd = -1;
}

void point_symlink(const std::string& link, const std::string& target) {
    const std::filesystem::path path(link);
    std::error_code ec;
    if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
    const std::string temp = link + ".tmp" + std::to_string(::getpid());
    ::unlink(temp.c_str());
    if (::symlink(target.c_str(), temp.c_str()) != 0) throw_errno("symlink");
    if (::rename(temp.c_str(), link.c_str()) != 0) {
        const int e = errno;
        ::unlink(temp.c_str());
        throw std::system_error(e, std::generic_category(), "rename symlink");
    }
}

void remove_symlink(const std::string& link) noexcept {
    struct stat st {};
    if (!link.empty() && ::lstat(link.c_str(), &st) == 0 && S_ISLNK(st.st_mode)) ::unlink(link.c_str());
}

}  // namespace gw::devices::sim
