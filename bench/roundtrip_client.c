// Command round trips, timed by a client light enough not to be what is measured (bench/roundtrip_vs_ser2net.py).
//
//   roundtrip_client line PORT N          "W X\r" over raw TCP (ser2net), the reply ends with '\n'
//   roundtrip_client http PORT N ID       POST /api/v1/controllers/ID/command {"command":"W X"}, keep-alive
//   roundtrip_client ws PORT N ID         {"op":"command",...,"operation":"command"} over /api/v1/ws
//   roundtrip_client pty PATH N           "W X\r" on a serial device or pty (a controller's own, or a shared one)
//
// Each mode does N round trips one after the other on one connection (after 50 unmeasured ones) and
// prints "n p50_us p90_us p99_us max_us mean_us". Loopback only (127.0.0.1). Exit code 1 on any error
// (a refused or malformed answer included).
#define _GNU_SOURCE  // memmem
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <sys/socket.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

enum { warmup = 50, buffer_bytes = 1 << 16 };

static char in[buffer_bytes];
static size_t in_len;

static void die(const char *what) {
    fprintf(stderr, "roundtrip_client: %s\n", what);
    exit(1);
}

static double now_us(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e6 + (double)t.tv_nsec / 1e3;
}

static int connect_loopback(int port) {
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons((unsigned short)port)};
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (fd < 0 || connect(fd, (struct sockaddr *)&a, sizeof a) != 0) die("cannot connect");
    int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    return fd;
}

static int open_raw(const char *path) {
    int fd = open(path, O_RDWR | O_NOCTTY);
    struct termios t;
    if (fd < 0 || tcgetattr(fd, &t) != 0) die("cannot open the device");
    cfmakeraw(&t);
    if (tcsetattr(fd, TCSANOW, &t) != 0) die("cannot make the device raw");
    return fd;
}

static void send_all(int fd, const char *p, size_t n) {
    while (n > 0) {
        ssize_t w = write(fd, p, n);
        if (w <= 0) die("write failed");
        p += w;
        n -= (size_t)w;
    }
}

static void fill(int fd) {
    if (in_len == sizeof in) die("answer too long");
    ssize_t r = read(fd, in + in_len, sizeof in - in_len);
    if (r <= 0) die("connection closed");
    in_len += (size_t)r;
}

static void consume(size_t n) {
    memmove(in, in + n, in_len - n);
    in_len -= n;
}

// Position of `needle` in the buffered input, or -1.
static long find(const char *needle) {
    size_t k = strlen(needle);
    for (size_t i = 0; i + k <= in_len; ++i)
        if (memcmp(in + i, needle, k) == 0) return (long)i;
    return -1;
}

static void line_round_trip(int fd) {
    send_all(fd, "W X\r", 4);
    long end;
    while ((end = find("\n")) < 0)
        fill(fd);
    if (in_len < 2 || in[0] != ':' || in[1] != 'A') die("the controller did not answer :A");
    consume((size_t)end + 1);
}

static char http_request[512];

static void http_round_trip(int fd) {
    send_all(fd, http_request, strlen(http_request));
    long head_end;
    while ((head_end = find("\r\n\r\n")) < 0)
        fill(fd);
    if (strncmp(in, "HTTP/1.1 200", 12) != 0) die("the gateway did not answer 200");
    long cl = find("Content-Length: ");
    if (cl < 0 || cl > head_end) die("no Content-Length");
    size_t body = strtoul(in + cl + 16, NULL, 10);
    size_t total = (size_t)head_end + 4 + body;
    while (in_len < total)
        fill(fd);
    consume(total);
}

static void ws_send_text(int fd, const char *text) {
    size_t n = strlen(text);
    unsigned char frame[600];
    if (n > 500) die("message too long");
    size_t h = 0;
    frame[h++] = 0x81;
    if (n < 126) {
        frame[h++] = (unsigned char)(0x80 | n);
    } else {
        frame[h++] = 0x80 | 126;
        frame[h++] = (unsigned char)(n >> 8);
        frame[h++] = (unsigned char)(n & 0xff);
    }
    const unsigned char mask[4] = {0x12, 0x34, 0x56, 0x78};
    memcpy(frame + h, mask, 4);
    h += 4;
    for (size_t i = 0; i < n; ++i)
        frame[h + i] = (unsigned char)text[i] ^ mask[i % 4];
    send_all(fd, (const char *)frame, h + n);
}

// Reads one whole server frame (unmasked, unfragmented text) into the front of `in`; returns its
// payload offset and sets *len. The caller consumes offset + len.
static size_t ws_read_frame(int fd, size_t *len) {
    while (in_len < 2)
        fill(fd);
    size_t n = (unsigned char)in[1] & 0x7f, off = 2;
    if (n == 126) {
        while (in_len < 4)
            fill(fd);
        n = ((size_t)(unsigned char)in[2] << 8) | (unsigned char)in[3];
        off = 4;
    } else if (n == 127) {
        die("frame too long");
    }
    while (in_len < off + n)
        fill(fd);
    *len = n;
    return off;
}

static int ws_id;
static char ws_controller[64];

static void ws_round_trip(int fd) {
    char msg[300];
    snprintf(msg, sizeof msg,
             "{\"op\":\"command\",\"id\":%d,\"controller\":\"%s\",\"operation\":\"command\","
             "\"args\":{\"command\":\"W X\"}}",
             ++ws_id, ws_controller);
    ws_send_text(fd, msg);
    for (;;) {
        size_t len, off = ws_read_frame(fd, &len);
        int result = memmem(in + off, len, "\"type\":\"result\"", 15) != NULL;
        int error = memmem(in + off, len, "\"type\":\"error\"", 14) != NULL;
        consume(off + len);
        if (error) die("the gateway answered an error");
        if (result) return;
    }
}

static void ws_upgrade(int fd) {
    const char *req =
        "GET /api/v1/ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n";
    send_all(fd, req, strlen(req));
    long head_end;
    while ((head_end = find("\r\n\r\n")) < 0)
        fill(fd);
    if (strncmp(in, "HTTP/1.1 101", 12) != 0) die("the upgrade was refused");
    consume((size_t)head_end + 4);
    size_t len, off = ws_read_frame(fd, &len);  // the hello
    consume(off + len);
}

static int by_value(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

int main(int argc, char **argv) {
    if (argc < 4) die("usage: roundtrip_client line|http|ws PORT N [CONTROLLER] | pty PATH N");
    const char *mode = argv[1];
    int n = atoi(argv[3]);
    if (n <= 0) die("N must be positive");
    void (*round_trip)(int) = NULL;
    int pty = strcmp(mode, "pty") == 0;
    int fd = pty ? open_raw(argv[2]) : connect_loopback(atoi(argv[2]));
    if (strcmp(mode, "line") == 0 || pty) {
        round_trip = line_round_trip;
    } else if (strcmp(mode, "http") == 0 && argc > 4) {
        const char *body = "{\"command\":\"W X\"}";
        snprintf(http_request, sizeof http_request,
                 "POST /api/v1/controllers/%s/command HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                 "Content-Type: application/json\r\nContent-Length: %zu\r\n\r\n%s",
                 argv[4], strlen(body), body);
        round_trip = http_round_trip;
    } else if (strcmp(mode, "ws") == 0 && argc > 4) {
        snprintf(ws_controller, sizeof ws_controller, "%s", argv[4]);
        ws_upgrade(fd);
        round_trip = ws_round_trip;
    } else {
        die("unknown mode (or a missing CONTROLLER)");
    }
    for (int i = 0; i < warmup; ++i)
        round_trip(fd);
    double *us = malloc(sizeof(double) * (size_t)n);
    if (!us) die("out of memory");
    double sum = 0;
    for (int i = 0; i < n; ++i) {
        double t0 = now_us();
        round_trip(fd);
        us[i] = now_us() - t0;
        sum += us[i];
    }
    qsort(us, (size_t)n, sizeof *us, by_value);
    printf("%d %.1f %.1f %.1f %.1f %.1f\n", n, us[n / 2], us[n * 9 / 10], us[n * 99 / 100], us[n - 1], sum / n);
    free(us);
    close(fd);
    return 0;
}
