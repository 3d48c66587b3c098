// The peer of bench/recordings_bench.py: position recordings written with SQLite alone, the physical
// cost the gateway's recorder is set against. Same file layout as gateway/recordings/recording_store.cpp
// (a `recordings` table with each recording's counters, `frames` WITHOUT ROWID keyed by (recording, seq),
// counts as 4 little-endian bytes per axis, micrometres as 8-byte doubles), same pragmas (WAL,
// synchronous FULL), same batching: every 250 ms ONE transaction holds every recording's new rows and
// their counters.
//
//   recording_writer DB RECORDINGS RATE_HZ SECONDS
//
// Frames "arrive" on a schedule, as the simulator's pulses do: frame k of recording r at
// start + (k + r / RECORDINGS) / RATE_HZ. At each 250 ms tick (absolute, so commits do not drift) the
// frames that have arrived are stored; a frame's latency is the end of its commit minus its arrival.
// Prints "ready initial_bytes B" once the schema is made (B: the file after a checkpoint), then at the
// end one line of "key value" pairs: frames, commits, cpu_s (user + system while writing), wall_s,
// p50_ms, p99_ms, max_ms (latency), txn_p50_ms, txn_max_ms (BEGIN to the end of COMMIT), write_bytes
// (what /proc/self/io says this process sent to the disk).
#define _GNU_SOURCE
#include <math.h>
#include <sqlite3.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <time.h>

enum { axes = 3, flush_ms = 250, latency_buckets = 20000 };  // 0.1 ms buckets up to 2 s

static sqlite3 *db;
static uint64_t latency_hist[latency_buckets + 1];

static void fail(const char *what) {
    fprintf(stderr, "recording_writer: %s: %s\n", what, db ? sqlite3_errmsg(db) : "?");
    exit(1);
}

static void exec(const char *sql) {
    if (sqlite3_exec(db, sql, NULL, NULL, NULL) != SQLITE_OK) fail(sql);
}

static int64_t now_us(void) {
    struct timespec t;
    clock_gettime(CLOCK_REALTIME, &t);
    return (int64_t)t.tv_sec * 1000000 + t.tv_nsec / 1000;
}

static void sleep_until_us(int64_t when) {
    struct timespec t = {.tv_sec = when / 1000000, .tv_nsec = (long)(when % 1000000) * 1000};
    while (clock_nanosleep(CLOCK_REALTIME, TIMER_ABSTIME, &t, NULL) != 0) {
    }
}

static double cpu_s(void) {
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return (double)u.ru_utime.tv_sec + u.ru_utime.tv_usec / 1e6 + (double)u.ru_stime.tv_sec + u.ru_stime.tv_usec / 1e6;
}

// The write_bytes line of /proc/self/io (0 when the kernel does not say).
static long long disk_write_bytes(void) {
    FILE *f = fopen("/proc/self/io", "r");
    long long v = 0;
    char line[128];
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, "write_bytes: %lld", &v) == 1) break;
    if (f) fclose(f);
    return v;
}

static int compare_doubles(const void *a, const void *b) {
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double percentile(double p) {
    uint64_t total = 0, seen = 0;
    for (int i = 0; i <= latency_buckets; ++i)
        total += latency_hist[i];
    const uint64_t want = (uint64_t)(p * (double)total);
    for (int i = 0; i <= latency_buckets; ++i) {
        seen += latency_hist[i];
        if (seen > want) return i / 10.0;
    }
    return latency_buckets / 10.0;
}

static void put_le(unsigned char *out, uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i)
        out[i] = (unsigned char)(v >> (8 * i));
}

static const char *schema =
    "CREATE TABLE recordings (key INTEGER PRIMARY KEY, id TEXT NOT NULL UNIQUE, controller TEXT NOT NULL,"
    " name TEXT NOT NULL, state TEXT NOT NULL, reason TEXT NOT NULL, started_ms INTEGER NOT NULL,"
    " stopped_ms INTEGER, frames INTEGER NOT NULL, losses INTEGER NOT NULL, axes TEXT NOT NULL,"
    " ttl_in_mode INTEGER NOT NULL, previous_in_mode INTEGER, max_frames INTEGER, max_s REAL,"
    " metadata TEXT NOT NULL);"
    "CREATE INDEX recordings_controller ON recordings(controller, started_ms);"
    "CREATE TABLE frames (recording INTEGER NOT NULL, seq INTEGER NOT NULL, idx INTEGER NOT NULL,"
    " time_us INTEGER NOT NULL, loss INTEGER NOT NULL, counts BLOB NOT NULL, um BLOB NOT NULL,"
    " PRIMARY KEY (recording, seq)) WITHOUT ROWID;";

int main(int argc, char **argv) {
    if (argc != 5) {
        fprintf(stderr, "usage: recording_writer DB RECORDINGS RATE_HZ SECONDS\n");
        return 2;
    }
    const char *path = argv[1];
    const int recordings = atoi(argv[2]);
    const double rate = atof(argv[3]), seconds = atof(argv[4]);
    const int64_t per_recording = llround(rate * seconds);
    if (recordings < 1 || rate <= 0 || per_recording < 1) {
        fprintf(stderr, "recording_writer: RECORDINGS, RATE_HZ and SECONDS must be positive\n");
        return 2;
    }
    if (sqlite3_open(path, &db) != SQLITE_OK) fail("open");
    exec("PRAGMA journal_mode = WAL");
    exec("PRAGMA synchronous = FULL");
    exec(schema);
    sqlite3_stmt *add_recording, *insert, *counters;
    if (sqlite3_prepare_v2(db,
                           "INSERT INTO recordings (key, id, controller, name, state, reason, started_ms, frames,"
                           " losses, axes, ttl_in_mode, previous_in_mode, metadata)"
                           " VALUES (?1, ?2, ?3, 'bench', 'recording', '', ?4, 0, 0, '', 1, 0, '{}')",
                           -1, &add_recording, NULL) != SQLITE_OK ||
        sqlite3_prepare_v2(db,
                           "INSERT INTO frames (recording, seq, idx, time_us, loss, counts, um)"
                           " VALUES (?1, ?2, ?3, ?4, 0, ?5, ?6)",
                           -1, &insert, NULL) != SQLITE_OK ||
        sqlite3_prepare_v2(db, "UPDATE recordings SET frames = ?2, losses = 0, axes = 'XYZ' WHERE key = ?1", -1,
                           &counters, NULL) != SQLITE_OK)
        fail("prepare");
    for (int r = 0; r < recordings; ++r) {
        char id[32], controller[32];
        snprintf(id, sizeof id, "r-peer-%03d", r);
        snprintf(controller, sizeof controller, "c-%d", r + 1);
        sqlite3_bind_int(add_recording, 1, r + 1);
        sqlite3_bind_text(add_recording, 2, id, -1, SQLITE_TRANSIENT);
        sqlite3_bind_text(add_recording, 3, controller, -1, SQLITE_TRANSIENT);
        sqlite3_bind_int64(add_recording, 4, now_us() / 1000);
        if (sqlite3_step(add_recording) != SQLITE_DONE) fail("add a recording");
        sqlite3_reset(add_recording);
    }
    // The starting size, with the WAL folded in, for the growth the script computes.
    exec("PRAGMA wal_checkpoint(TRUNCATE)");
    struct stat st;
    printf("ready initial_bytes %lld\n", stat(path, &st) == 0 ? (long long)st.st_size : 0LL);
    fflush(stdout);

    int64_t *stored = calloc((size_t)recordings, sizeof *stored);  // frames stored per recording
    if (!stored) fail("calloc");
    const double cpu_before = cpu_s();
    const long long io_before = disk_write_bytes();
    const int64_t start = now_us();
    uint64_t frames = 0, commits = 0;
    // Arrival times of the frames in the current commit (room for all of them: a late tick takes more).
    int64_t *arrivals = malloc(sizeof *arrivals * (size_t)per_recording * (size_t)recordings);
    if (!arrivals) fail("malloc");
    // How long each transaction took, from BEGIN to the end of COMMIT (its fsync included).
    const size_t max_commits = (size_t)(seconds * 1000 / flush_ms) + 16;
    double *txn_ms = malloc(sizeof *txn_ms * max_commits);
    if (!txn_ms) fail("malloc");
    for (int64_t tick = start + flush_ms * 1000;; tick += flush_ms * 1000) {
        sleep_until_us(tick);
        const int64_t now = now_us();
        size_t batch = 0;
        exec("BEGIN IMMEDIATE");
        for (int r = 0; r < recordings; ++r) {
            const int64_t before = stored[r];
            for (int64_t k = stored[r]; k < per_recording; ++k) {
                const int64_t arrival = start + llround((k + (double)r / recordings) * 1e6 / rate);
                if (arrival > now) break;
                // The stage at a slowly moving position: counts and micrometres change from frame to frame.
                unsigned char counts[4 * axes], um[8 * axes];
                for (int a = 0; a < axes; ++a) {
                    const int32_t c = (int32_t)(k * (a + 1));
                    const double u = c / 10.0;
                    uint64_t bits;
                    memcpy(&bits, &u, sizeof bits);
                    put_le(counts + 4 * a, (uint32_t)c, 4);
                    put_le(um + 8 * a, bits, 8);
                }
                sqlite3_bind_int(insert, 1, r + 1);
                sqlite3_bind_int64(insert, 2, k);
                sqlite3_bind_int64(insert, 3, k);
                sqlite3_bind_int64(insert, 4, arrival);
                sqlite3_bind_blob(insert, 5, counts, sizeof counts, SQLITE_STATIC);
                sqlite3_bind_blob(insert, 6, um, sizeof um, SQLITE_STATIC);
                if (sqlite3_step(insert) != SQLITE_DONE) fail("insert a frame");
                sqlite3_reset(insert);
                arrivals[batch++] = arrival;
                stored[r] = k + 1;
            }
            if (stored[r] == before) continue;
            sqlite3_bind_int(counters, 1, r + 1);
            sqlite3_bind_int64(counters, 2, stored[r]);
            if (sqlite3_step(counters) != SQLITE_DONE) fail("update the counters");
            sqlite3_reset(counters);
        }
        exec("COMMIT");
        const int64_t durable = now_us();
        if (commits < max_commits) txn_ms[commits] = (durable - now) / 1e3;
        ++commits;
        frames += batch;
        for (size_t i = 0; i < batch; ++i) {
            int64_t bucket = (durable - arrivals[i]) / 100;
            latency_hist[bucket < 0 ? 0 : bucket > latency_buckets ? latency_buckets : bucket]++;
        }
        if (stored[recordings - 1] >= per_recording) break;  // the last recording's frames arrive last
    }
    const double cpu = cpu_s() - cpu_before;
    const long long written = disk_write_bytes() - io_before;
    const double wall = (now_us() - start) / 1e6;
    sqlite3_finalize(add_recording);
    sqlite3_finalize(insert);
    sqlite3_finalize(counters);
    if (sqlite3_close(db) != SQLITE_OK) fail("close");
    const size_t timed = commits < max_commits ? commits : max_commits;
    qsort(txn_ms, timed, sizeof *txn_ms, compare_doubles);
    printf("frames %llu commits %llu cpu_s %.3f wall_s %.3f p50_ms %.1f p99_ms %.1f max_ms %.1f txn_p50_ms %.1f "
           "txn_max_ms %.1f write_bytes %lld\n",
           (unsigned long long)frames, (unsigned long long)commits, cpu, wall, percentile(0.5), percentile(0.99),
           percentile(1.0 - 1e-9), txn_ms[timed / 2], txn_ms[timed - 1], written);
    free(txn_ms);
    free(arrivals);
    free(stored);
    return 0;
}
