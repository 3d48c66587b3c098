/* A slow disk on demand, for bench/store_latency.py --fsync-delay-ms: preloaded into the gateway
 * (LD_PRELOAD), it makes every fsync and fdatasync take GW_BENCH_FSYNC_DELAY_US microseconds longer,
 * as a busy or rotational disk does. The call itself still happens, so what is committed is durable.
 *
 *   cc -shared -fPIC -O2 -o slow_fsync.so bench/slow_fsync.c -ldl
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdlib.h>
#include <unistd.h>

static void delay(void) {
    const char* text = getenv("GW_BENCH_FSYNC_DELAY_US");
    long us = text ? atol(text) : 0;
    if (us > 0) usleep((useconds_t)us);
}

int fsync(int fd) {
    static int (*real)(int);
    if (!real) real = (int (*)(int))dlsym(RTLD_NEXT, "fsync");
    delay();
    return real(fd);
}

int fdatasync(int fd) {
    static int (*real)(int);
    if (!real) real = (int (*)(int))dlsym(RTLD_NEXT, "fdatasync");
    delay();
    return real(fd);
}
