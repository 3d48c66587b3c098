// Encoder report frames on many pseudo-terminals at a steady rate, lighter than the simulator, so that
// on a small machine the rig is not what limits a fan-out benchmark (bench/fanout.py).
//
//   report_generator DIR COUNT RATE_HZ
//
// Creates COUNT ptys with symlinks DIR/r0 .. DIR/r<COUNT-1> (each a controller's report port for the
// gateway), prints "ready", and waits. SIGUSR1 starts the frames: every 1/RATE_HZ s, one binary
// TTL_REPORT frame (X Y Z: AID 0x18..0x1A, a 32-bit little-endian count each, then CR; 16 bytes, see
// devices/ms2000/report_frame.hpp) to every pty. SIGTERM stops and prints "written W refused R late L":
// frames written, frames the pty did not take (its buffer full: nobody reads), and ticks that came
// later than one period (the generator itself fell behind). The ptys then stay open until the process
// is killed: closing a master hangs its slave up and discards what the gateway had not read yet.
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "paced_run.h"

static int open_pty(const char *link) {
    int master = posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (master < 0 || grantpt(master) != 0 || unlockpt(master) != 0) die("posix_openpt");
    const char *slave_name = ptsname(master);
    // Raw from the start, so that a CR is never turned into a newline before the gateway's own
    // settings apply; the slave stays open so that writes never fail for want of a reader.
    int slave = open(slave_name, O_RDWR | O_NOCTTY);
    if (slave < 0) die("open the pty's slave");
    struct termios t;
    if (tcgetattr(slave, &t) != 0) die("tcgetattr");
    cfmakeraw(&t);
    if (tcsetattr(slave, TCSANOW, &t) != 0) die("tcsetattr");
    unlink(link);
    if (symlink(slave_name, link) != 0) die("symlink");
    return master;
}

static void put_le32(uint8_t *p, int32_t v) {
    uint32_t u = (uint32_t)v;
    for (int i = 0; i < 4; ++i)
        p[i] = (uint8_t)(u >> (8 * i));
}

int main(int argc, char **argv) {
    program_name = "report_generator";
    if (argc != 4) {
        fprintf(stderr, "usage: report_generator DIR COUNT RATE_HZ\n");
        return 2;
    }
    const int count = atoi(argv[2]);
    const double rate = atof(argv[3]);
    if (count <= 0 || count > 1024 || rate <= 0) {
        fprintf(stderr, "report_generator: COUNT 1..1024, RATE_HZ > 0\n");
        return 2;
    }
    int *masters = calloc((size_t)count, sizeof *masters);
    if (!masters) die("calloc");
    for (int i = 0; i < count; ++i) {
        char link[4096];
        snprintf(link, sizeof link, "%s/r%d", argv[1], i);
        masters[i] = open_pty(link);
    }
    printf("ready\n");
    fflush(stdout);
    wait_for_start();

    struct ticker ticker;
    ticker_start(&ticker, rate);
    uint64_t written = 0, refused = 0;
    int32_t n = 0;
    uint8_t frame[16];
    while (!stopping) {
        ++n;
        for (int axis = 0; axis < 3; ++axis) {
            frame[axis * 5] = (uint8_t)(0x18 + axis);
            put_le32(frame + axis * 5 + 1, n * (axis + 1));
        }
        frame[15] = 0x0D;
        for (int i = 0; i < count; ++i) {
            if (write(masters[i], frame, sizeof frame) == (ssize_t)sizeof frame)
                ++written;
            else
                ++refused;
        }
        ticker_wait(&ticker);
    }
    printf("written %llu refused %llu late %llu\n", (unsigned long long)written, (unsigned long long)refused,
           (unsigned long long)ticker.late);
    fflush(stdout);
    for (;;)
        pause();
}
