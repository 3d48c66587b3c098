#pragma once
// Pseudo-terminal pairs and stable symlinks for the simulator's ports. Synchronous, called from
// simulator::start()/replug() only (never blocks: posix_openpt and symlink are immediate).

#include <string>

namespace gw::devices::sim {

// The master side is what the simulator reads and writes (non-blocking); the slave side is what a
// client opens through the symlink. The simulator keeps its own slave descriptor open, so the
// master never sees EIO when a client closes and reopens the port, and sets it raw (no echo, no
// CR/LF translation), the way a real serial port behaves.
struct pty_pair {
    int master = -1;
    int slave = -1;
    std::string slave_path;  // "/dev/pts/7"
};

// Throws std::system_error.
pty_pair open_pty();
void close_fd(int& fd);

// Creates the parent directories and points `link` at `target`, replacing an existing link
// atomically (symlink to a temporary name, then rename). Throws std::system_error.
void point_symlink(const std::string& link, const std::string& target);
// Removes `link` if it is a symlink; never throws.
void remove_symlink(const std::string& link) noexcept;

}  // namespace gw::devices::sim
