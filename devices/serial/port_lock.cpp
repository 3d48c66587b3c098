#include "devices/serial/port_lock.hpp"

#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <termios.h>
#include <unistd.h>

namespace gw::devices {

int lock_port(int fd) {
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return 0;
    return errno == EWOULDBLOCK ? EBUSY : errno;
}

bool tty_in_exclusive_mode(int fd) {
#ifdef TIOCGEXCL
    int exclusive = 0;
    return ::ioctl(fd, TIOCGEXCL, &exclusive) == 0 && exclusive != 0;
#else
    (void)fd;
    return false;
#endif
}

std::optional<std::string> uucp_lock_holder(const std::string& device_path) {
    const auto slash = device_path.rfind('/');
    const std::string name = device_path.substr(slash == std::string::npos ? 0 : slash + 1);
    for (const char* dir : {"/run/lock/", "/var/lock/"}) {
        const std::string file = std::string(dir) + "LCK.." + name;
        std::ifstream in(file, std::ios::binary);
        if (!in) continue;
        // The pid is ten ASCII digits (HDB style) or, in old files, a binary int.
        std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        long pid = 0;
        try {
            pid = std::stol(content);
        } catch (const std::exception&) {
            if (content.size() == sizeof(std::int32_t)) {
                std::int32_t binary = 0;
                std::memcpy(&binary, content.data(), sizeof binary);
                pid = binary;
            }
        }
        if (pid <= 0) continue;
        if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM)
            return "lock file " + file + " (pid " + std::to_string(pid) + ")";
    }
    return std::nullopt;
}

namespace {

// Unix98 pty slaves have majors 136..143 (Documentation/admin-guide/devices.txt).
bool is_pty_slave(const std::string& device) {
    struct stat st {};
    if (::stat(device.c_str(), &st) != 0 || !S_ISCHR(st.st_mode)) return false;
    const auto m = major(st.st_rdev);
    return m >= 136 && m <= 143;
}

std::string process_name(const std::filesystem::path& proc_dir) {
    std::ifstream in(proc_dir / "comm");
    std::string name;
    std::getline(in, name);
    return name;
}

}  // namespace

std::map<std::string, std::string> open_elsewhere(const std::vector<std::string>& devices) {
    std::set<std::string> wanted;
    for (const auto& d : devices)
        if (!d.empty() && !is_pty_slave(d)) wanted.insert(d);
    std::map<std::string, std::string> held;
    if (wanted.empty()) return held;
    const std::string self = std::to_string(::getpid());
    std::error_code ec;
    for (std::filesystem::directory_iterator proc("/proc", ec), end; !ec && proc != end; proc.increment(ec)) {
        const std::string pid = proc->path().filename().string();
        if (pid.empty() || pid.find_first_not_of("0123456789") != std::string::npos || pid == self) continue;
        std::error_code fd_ec;
        for (std::filesystem::directory_iterator fd(proc->path() / "fd", fd_ec), fd_end;
             !fd_ec && fd != fd_end; fd.increment(fd_ec)) {
            // readlink, not stat: a descriptor on a hung file system must not stall the probe.
            char target[4096];
            const auto n = ::readlink(fd->path().c_str(), target, sizeof target - 1);
            if (n <= 0) continue;
            const std::string device(target, static_cast<std::size_t>(n));
            if (wanted.count(device) && !held.count(device))
                held[device] = "pid " + pid + " (" + process_name(proc->path()) + ") has it open";
        }
    }
    return held;
}

}  // namespace gw::devices
