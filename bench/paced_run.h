// What the frame sources of the fan-out benchmark share (bench/report_generator.c,
// bench/mqtt_report_publisher.c): SIGUSR1 starts them, SIGTERM stops them, and a tick every period
// on the monotonic clock, with the ticks that came late counted (the source itself fell behind).
#ifndef PACED_RUN_H
#define PACED_RUN_H

#include <errno.h>
#include <signal.h>
#include <stdint.h>
#include <time.h>
#include <unistd.h>

#include "fanout_common.h"

static volatile sig_atomic_t started;

static void on_start(int sig) {
    (void)sig;
    started = 1;
}

// Installs the handlers, then waits for SIGUSR1 (or a stop).
static inline void wait_for_start(void) {
    signal(SIGUSR1, on_start);
    stop_on_signals();
    while (!started && !stopping)
        pause();
}

struct ticker {
    long period_ns;
    struct timespec next;
    uint64_t late;
};

static inline void ticker_start(struct ticker *t, double rate_hz) {
    t->period_ns = (long)(1e9 / rate_hz);
    t->late = 0;
    clock_gettime(CLOCK_MONOTONIC, &t->next);
}

// Sleeps until the next tick; a tick already past counts as late.
static inline void ticker_wait(struct ticker *t) {
    t->next.tv_nsec += t->period_ns;
    while (t->next.tv_nsec >= 1000000000L) {
        t->next.tv_nsec -= 1000000000L;
        ++t->next.tv_sec;
    }
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    if (now.tv_sec > t->next.tv_sec || (now.tv_sec == t->next.tv_sec && now.tv_nsec > t->next.tv_nsec)) ++t->late;
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t->next, NULL) == EINTR && !stopping) {
    }
}

#endif
