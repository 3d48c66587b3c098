#pragma once
// A test fake for a storage that fails at run time: a SQLite VFS that wraps the default one and, while
// told to, refuses every write of a file (xWrite, xTruncate) with a given SQLite code: SQLITE_FULL as a
// full disk gives, SQLITE_IOERR_WRITE as a file system remounted read-only gives (EROFS), or
// SQLITE_READONLY. A real disk cannot be filled or remounted on demand without privileges; everything
// else (reads, locks, the WAL index) is the real VFS.
//
//   gw::test::failing_vfs vfs;          // the default VFS from now on (for connections opened later)
//   open the store ...
//   vfs.fail_writes(SQLITE_FULL);       // every write fails
//   vfs.fail_writes(0);                 // writes work again
//                                       // the destructor restores the previous default VFS
//
// One at a time per process; the connections opened through it must be closed before it is destroyed.

#include <atomic>
#include <cstring>
#include <sqlite3.h>
#include <stdexcept>

namespace gw::test {

class failing_vfs {
  public:
    failing_vfs() {
        real_ = sqlite3_vfs_find(nullptr);
        if (!real_ || real_ == &vfs_)
            throw std::logic_error("failing_vfs: no default VFS, or already in use");
        vfs_ = *real_;  // the real methods: they ignore which sqlite3_vfs* calls them, except xOpen
        vfs_.pNext = nullptr;
        vfs_.zName = "gw-test-failing-vfs";
        vfs_.szOsFile = static_cast<int>(sizeof(file)) + real_->szOsFile;
        vfs_.xOpen = &open;
        methods_ = make_methods();
        fault_ = 0;
        failed_ = 0;
        if (sqlite3_vfs_register(&vfs_, 1) != SQLITE_OK) throw std::runtime_error("failing_vfs: register");
    }
    ~failing_vfs() {
        sqlite3_vfs_unregister(&vfs_);
        sqlite3_vfs_register(real_, 1);  // the default again
    }
    failing_vfs(const failing_vfs&) = delete;
    failing_vfs& operator=(const failing_vfs&) = delete;

    // 0: writes work. Otherwise every write fails with this code (SQLITE_FULL, SQLITE_IOERR_WRITE, ...).
    void fail_writes(int code) { fault_ = code; }
    // Writes refused since construction.
    int writes_refused() const { return failed_; }

  private:
    // Ours, followed in memory by the real VFS's file object (szOsFile covers both).
    struct file {
        sqlite3_file base;
        sqlite3_file* real() { return reinterpret_cast<sqlite3_file*>(this + 1); }
    };
    static sqlite3_file* real(sqlite3_file* f) { return reinterpret_cast<file*>(f)->real(); }

    static int refused() {
        ++failed_;
        return fault_;
    }

    static int open(sqlite3_vfs*, const char* name, sqlite3_file* f, int flags, int* out_flags) {
        auto* ours = reinterpret_cast<file*>(f);
        ours->base.pMethods = nullptr;
        int rc = real_->xOpen(real_, name, ours->real(), flags, out_flags);
        if (ours->real()->pMethods) ours->base.pMethods = &methods_;
        return rc;
    }

    static int version(sqlite3_file* f) { return real(f)->pMethods->iVersion; }

    // Every method forwards to the real file's; the shared-memory and memory-map ones (versions 2 and 3)
    // answer as a VFS without them would when the real file lacks them.
    static sqlite3_io_methods make_methods() {
        sqlite3_io_methods m{};
        m.iVersion = 3;
        m.xClose = [](sqlite3_file* f) {
            int rc = real(f)->pMethods->xClose(real(f));
            f->pMethods = nullptr;
            return rc;
        };
        m.xRead = [](sqlite3_file* f, void* p, int n, sqlite3_int64 at) {
            return real(f)->pMethods->xRead(real(f), p, n, at);
        };
        m.xWrite = [](sqlite3_file* f, const void* p, int n, sqlite3_int64 at) {
            if (fault_ != 0) return refused();
            return real(f)->pMethods->xWrite(real(f), p, n, at);
        };
        m.xTruncate = [](sqlite3_file* f, sqlite3_int64 size) {
            if (fault_ != 0) return refused();
            return real(f)->pMethods->xTruncate(real(f), size);
        };
        m.xSync = [](sqlite3_file* f, int flags) { return real(f)->pMethods->xSync(real(f), flags); };
        m.xFileSize = [](sqlite3_file* f, sqlite3_int64* size) {
            return real(f)->pMethods->xFileSize(real(f), size);
        };
        m.xLock = [](sqlite3_file* f, int l) { return real(f)->pMethods->xLock(real(f), l); };
        m.xUnlock = [](sqlite3_file* f, int l) { return real(f)->pMethods->xUnlock(real(f), l); };
        m.xCheckReservedLock = [](sqlite3_file* f, int* out) {
            return real(f)->pMethods->xCheckReservedLock(real(f), out);
        };
        m.xFileControl = [](sqlite3_file* f, int op, void* arg) {
            return real(f)->pMethods->xFileControl(real(f), op, arg);
        };
        m.xSectorSize = [](sqlite3_file* f) { return real(f)->pMethods->xSectorSize(real(f)); };
        m.xDeviceCharacteristics = [](sqlite3_file* f) {
            return real(f)->pMethods->xDeviceCharacteristics(real(f));
        };
        m.xShmMap = [](sqlite3_file* f, int page, int size, int extend, void volatile** p) {
            if (version(f) < 2) return SQLITE_IOERR_SHMMAP;
            return real(f)->pMethods->xShmMap(real(f), page, size, extend, p);
        };
        m.xShmLock = [](sqlite3_file* f, int offset, int n, int flags) {
            if (version(f) < 2) return SQLITE_IOERR_SHMLOCK;
            return real(f)->pMethods->xShmLock(real(f), offset, n, flags);
        };
        m.xShmBarrier = [](sqlite3_file* f) {
            if (version(f) >= 2) real(f)->pMethods->xShmBarrier(real(f));
        };
        m.xShmUnmap = [](sqlite3_file* f, int remove) {
            if (version(f) < 2) return SQLITE_OK;
            return real(f)->pMethods->xShmUnmap(real(f), remove);
        };
        m.xFetch = [](sqlite3_file* f, sqlite3_int64 at, int n, void** p) {
            if (version(f) < 3) {
                *p = nullptr;  // no mapping: SQLite reads instead
                return SQLITE_OK;
            }
            return real(f)->pMethods->xFetch(real(f), at, n, p);
        };
        m.xUnfetch = [](sqlite3_file* f, sqlite3_int64 at, void* p) {
            if (version(f) < 3) return SQLITE_OK;
            return real(f)->pMethods->xUnfetch(real(f), at, p);
        };
        return m;
    }

    // SQLite keeps pointers to these while connections are open: one instance at a time.
    static inline sqlite3_vfs* real_ = nullptr;
    static inline sqlite3_vfs vfs_{};
    static inline sqlite3_io_methods methods_{};
    static inline std::atomic<int> fault_{0};
    static inline std::atomic<int> failed_{0};
};

}  // namespace gw::test
