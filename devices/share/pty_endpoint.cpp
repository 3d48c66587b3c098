#include "devices/share/pty_endpoint.hpp"

#include <array>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <grp.h>
#include <poll.h>
#include <sys/stat.h>
#include <system_error>
#include <termios.h>
#include <unistd.h>
#include <vector>

namespace gw::devices::share {

namespace {

std::string errno_text(const char* what) {
    return std::string(what) + ": " + std::strerror(errno);
}

// The group's id, or why not.
std::string group_id(const std::string& name, gid_t& gid) {
    std::vector<char> buffer(16384);
    group entry{};
    group* found = nullptr;
    const int rc = getgrnam_r(name.c_str(), &entry, buffer.data(), buffer.size(), &found);
    if (rc != 0 || !found) return "no group \"" + name + "\"";
    gid = found->gr_gid;
    return {};
}

}  // namespace

pty_endpoint::pty_endpoint(const boost::asio::strand<boost::asio::any_io_executor>& strand)
    : master_(strand) {}

pty_endpoint::~pty_endpoint() {
    close();
}

std::string pty_endpoint::open(const share_settings& settings, std::string& warning) {
    const int master = posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (master < 0) return errno_text("posix_openpt");
    std::array<char, 128> name{};
    if (grantpt(master) != 0 || unlockpt(master) != 0 || ptsname_r(master, name.data(), name.size()) != 0) {
        auto why = errno_text("grantpt/unlockpt/ptsname");
        ::close(master);
        return why;
    }
    slave_name_ = name.data();
    // Raw mode is set on the slave once; the pty keeps it while the master is open.
    const int slave = ::open(slave_name_.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (slave < 0) {
        auto why = errno_text(slave_name_.c_str());
        ::close(master);
        return why;
    }
    termios mode{};
    if (tcgetattr(slave, &mode) == 0) {
        cfmakeraw(&mode);
        tcsetattr(slave, TCSANOW, &mode);
    }
    ::close(slave);
    if (!settings.pty_group.empty()) {
        gid_t gid = 0;
        auto why = group_id(settings.pty_group, gid);
        if (why.empty() && chown(slave_name_.c_str(), static_cast<uid_t>(-1), gid) != 0)
            why = errno_text("chown");
        if (!why.empty()) warning = "group " + settings.pty_group + " not set on " + slave_name_ + ": " + why;
    }
    if (chmod(slave_name_.c_str(), settings.pty_mode) != 0) warning = errno_text("chmod");

    struct stat existing {};
    if (lstat(settings.pty.c_str(), &existing) == 0) {
        if (!S_ISLNK(existing.st_mode)) {
            ::close(master);
            return settings.pty + " exists and is not a symbolic link: not replaced";
        }
        ::unlink(settings.pty.c_str());
    }
    if (symlink(slave_name_.c_str(), settings.pty.c_str()) != 0) {
        auto why = errno_text(settings.pty.c_str());
        ::close(master);
        return why;
    }
    link_ = settings.pty;
    master_.assign(master);
    return {};
}

void pty_endpoint::close() {
    boost::system::error_code ignored;
    master_.close(ignored);
    if (link_.empty()) return;
    std::array<char, 256> target{};
    const auto n = readlink(link_.c_str(), target.data(), target.size() - 1);
    if (n > 0 && std::string(target.data(), static_cast<std::size_t>(n)) == slave_name_)
        ::unlink(link_.c_str());
    link_.clear();
}

bool pty_endpoint::program_present() {
    if (!master_.is_open()) return false;
    pollfd p{master_.native_handle(), POLLIN, 0};
    if (::poll(&p, 1, 0) < 0) return false;
    return (p.revents & POLLHUP) == 0;
}

}  // namespace gw::devices::share
