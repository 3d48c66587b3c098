// What the fan-out clients share (bench/fanout_client.c for WebSocket, bench/mqtt_fanout_client.c for
// MQTT): sockets, the clock, and the latency histogram with its per-second worst case.
#ifndef FANOUT_COMMON_H
#define FANOUT_COMMON_H

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

enum { latency_buckets = 10000, timeline_seconds = 600 };  // 0.1 ms buckets up to 1 s

static const char *program_name = "fanout";
static volatile sig_atomic_t stopping;
static uint64_t latency_hist[latency_buckets + 1];
static double second_max_ms[timeline_seconds];  // the worst latency seen in each second of the run
static double start_ms;

static inline void die(const char *what) {
    fprintf(stderr, "%s: %s: %s\n", program_name, what, strerror(errno));
    exit(1);
}

static void on_stop(int sig) {
    (void)sig;
    stopping = 1;
}

// SIGTERM and SIGINT end the run; a peer that went away is a closed connection, not a signal.
static inline void stop_on_signals(void) {
    signal(SIGTERM, on_stop);
    signal(SIGINT, on_stop);
    signal(SIGPIPE, SIG_IGN);
}

// Wall-clock milliseconds: the gateway's timestamps are wall-clock, and it runs on this machine.
static inline double now_ms(void) {
    struct timespec t;
    clock_gettime(CLOCK_REALTIME, &t);
    return (double)t.tv_sec * 1e3 + (double)t.tv_nsec / 1e6;
}

static inline int fcntl_nonblock(int fd) {
    int flags = fcntl(fd, F_GETFL);
    return flags < 0 ? -1 : fcntl(fd, F_SETFL, flags | O_NONBLOCK);
}

static inline void send_all(int fd, const void *p, size_t n) {
    const char *c = p;
    while (n > 0) {
        ssize_t w = write(fd, c, n);
        if (w < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) continue;  // a small reply on a full socket
        if (w <= 0) die("write");
        c += w;
        n -= (size_t)w;
    }
}

static inline int connect_loopback(int port) {
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (fd < 0 || connect(fd, (struct sockaddr *)&a, sizeof a) != 0) die("connect");
    int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    return fd;
}

// A connection's input: what has arrived and not yet been parsed.
struct input_buffer {
    char *data;
    size_t len, cap;
};

// Reads everything the socket has (it is non-blocking); returns 0 when the peer closed.
static inline int read_available(int fd, struct input_buffer *in) {
    for (;;) {
        if (in->cap - in->len < 65536) {
            in->cap = in->cap ? in->cap * 2 : 1 << 20;
            in->data = realloc(in->data, in->cap);
            if (!in->data) die("realloc");
        }
        ssize_t r = read(fd, in->data + in->len, in->cap - in->len);
        if (r < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return 1;
        if (r <= 0) return 0;
        in->len += (size_t)r;
    }
}

// Drops the first `parsed` bytes.
static inline void consume(struct input_buffer *in, size_t parsed) {
    memmove(in->data, in->data + parsed, in->len - parsed);
    in->len -= parsed;
}

// One delivery: sent_ms is the sender's clock when the frame arrived there, t when it was read here.
static inline void record_latency(double sent_ms, double t) {
    long bucket = (long)((t - sent_ms) * 10);
    if (bucket < 0) bucket = 0;
    if (bucket > latency_buckets) bucket = latency_buckets;
    ++latency_hist[bucket];
    const long second = (long)((t - start_ms) / 1000);
    if (second >= 0 && second < timeline_seconds && t - sent_ms > second_max_ms[second])
        second_max_ms[second] = t - sent_ms;
}

// -1 when no latency was recorded.
static inline double latency_percentile(double p) {
    uint64_t total = 0, seen = 0;
    for (int i = 0; i <= latency_buckets; ++i)
        total += latency_hist[i];
    if (total == 0) return -1;  // nothing arrived
    const uint64_t want = (uint64_t)(p * (double)total);
    for (int i = 0; i <= latency_buckets; ++i) {
        seen += latency_hist[i];
        if (seen > want) return i / 10.0;
    }
    return latency_buckets / 10.0;
}

// The worst latency of each second, for telling a steady tail from a burst (stderr).
static inline void print_timeline(void) {
    for (int i = 0; i < timeline_seconds && i <= (int)((now_ms() - start_ms) / 1000); ++i)
        fprintf(stderr, "second %d max_ms %.1f\n", i, second_max_ms[i]);
}

// What every client connection has: first in each client program's struct client.
struct connection {
    int fd;
    int closed;  // by the server
    struct input_buffer in;
    uint64_t events;
    uint64_t missed;  // what gap events told it missed
};

static inline struct connection *connection_at(void *clients, size_t size, int index) {
    return (struct connection *)((char *)clients + (size_t)index * size);
}

// Watches the connection (made non-blocking) under its index.
static inline void watch(int ep, struct connection *c, int index) {
    struct epoll_event e = {.events = EPOLLIN, .data.u32 = (uint32_t)index};
    if (epoll_ctl(ep, EPOLL_CTL_ADD, c->fd, &e) != 0) die("epoll_ctl");
    if (fcntl_nonblock(c->fd) != 0) die("nonblock");
}

// Until a stop signal: on_readable for every connection with input; 0 from it means the server
// closed the connection.
static inline void serve(int ep, void *clients, size_t size, int (*on_readable)(struct connection *)) {
    struct epoll_event ready[64];
    while (!stopping) {
        int n = epoll_wait(ep, ready, 64, 200);
        for (int k = 0; k < n; ++k) {
            struct connection *c = connection_at(clients, size, (int)ready[k].data.u32);
            if (!c->closed && !on_readable(c)) {
                c->closed = 1;
                epoll_ctl(ep, EPOLL_CTL_DEL, c->fd, NULL);
            }
        }
    }
}

// "clients N closed C events E min_events A max_events B min_accounted X max_accounted Y " (the start
// of the summary line). Accounted: a client's events plus what it was told it missed; with every
// frame accounted for, the same for every client, and the number of frames published.
static inline void print_counts(void *clients, size_t size, int count) {
    uint64_t total = 0, min = UINT64_MAX, max = 0, closed = 0, min_accounted = UINT64_MAX, max_accounted = 0;
    for (int i = 0; i < count; ++i) {
        const struct connection *c = connection_at(clients, size, i);
        total += c->events;
        if (c->events < min) min = c->events;
        if (c->events > max) max = c->events;
        const uint64_t accounted = c->events + c->missed;
        if (accounted < min_accounted) min_accounted = accounted;
        if (accounted > max_accounted) max_accounted = accounted;
        closed += (uint64_t)c->closed;
    }
    printf("clients %d closed %llu events %llu min_events %llu max_events %llu min_accounted %llu max_accounted %llu ",
           count, (unsigned long long)closed, (unsigned long long)total, (unsigned long long)min,
           (unsigned long long)max, (unsigned long long)min_accounted, (unsigned long long)max_accounted);
}

// " p50_ms P p99_ms Q max_ms M" and the end of the summary line, then the timeline on stderr.
static inline void print_latencies(void) {
    printf("p50_ms %.1f p99_ms %.1f max_ms %.1f\n", latency_percentile(0.5), latency_percentile(0.99),
           latency_percentile(1.0 - 1e-9));
    print_timeline();
}

#endif
