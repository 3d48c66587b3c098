// Many WebSocket clients of one gateway in one process (epoll), light enough that a fan-out benchmark
// measures the gateway, not the clients (bench/fanout.py).
//
//   fanout_client PORT CLIENTS BATCH_MS TOPIC
//
// Opens CLIENTS connections to ws://127.0.0.1:PORT/api/v1/ws (?batch_ms=BATCH_MS unless it is -1),
// subscribes each to TOPIC, prints "subscribed", then reads until SIGTERM. Every event is counted
// and its latency taken: the time it is read here minus its "time_ms" (the gateway's clock when the
// frame's bytes arrived; one machine, one clock). Gap events add their "missed". At the end it prints
// one line of "key value" pairs: clients, closed (connections the gateway ended), events (all
// clients), min_events and max_events (per client), min_accounted and max_accounted (per client:
// events plus missed), missed, p50_ms, p99_ms, max_ms.
#define _GNU_SOURCE
#include <signal.h>
#include <sys/epoll.h>

#include "fanout_common.h"

enum { max_clients = 1024 };

struct client {
    struct connection base;  // first: serve() and print_counts() see it
    char *message;  // a fragmented message being put together
    size_t message_len, message_cap;
    int in_text;  // the fragments are of a text message
};

static uint64_t missed_total;

static void send_text(int fd, const char *text) {
    size_t n = strlen(text);
    uint8_t head[8] = {0x81, (uint8_t)(0x80 | n), 1, 2, 3, 4};
    if (n >= 126) die("subscribe message too long");
    uint8_t masked[126];
    for (size_t i = 0; i < n; ++i)
        masked[i] = (uint8_t)text[i] ^ head[2 + i % 4];
    send_all(fd, head, 6);
    send_all(fd, masked, n);
}

static int connect_ws(int port, int batch_ms) {
    int fd = connect_loopback(port);
    char req[512], query[32] = "";
    if (batch_ms >= 0) snprintf(query, sizeof query, "?batch_ms=%d", batch_ms);
    snprintf(req, sizeof req,
             "GET /api/v1/ws%s HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
             "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n",
             query);
    send_all(fd, req, strlen(req));
    // The 101 answer, byte by byte so that nothing after it is read here.
    char head[2048];
    size_t n = 0;
    while (n < sizeof head - 1) {
        if (read(fd, head + n, 1) != 1) die("upgrade");
        ++n;
        if (n >= 4 && memcmp(head + n - 4, "\r\n\r\n", 4) == 0) break;
    }
    head[n] = 0;
    if (strncmp(head, "HTTP/1.1 101", 12) != 0) {
        fprintf(stderr, "fanout_client: upgrade refused: %s\n", head);
        exit(1);
    }
    return fd;
}

// Where `needle` starts in [p, end), or NULL. memchr looks for its byte at `anchor`, chosen rare in
// the gateway's messages, then the whole needle is compared. (glibc's memmem builds a shift table on
// every call: with two calls per event it was most of this client's CPU.)
static const char *find(const char *p, const char *end, const char *needle, size_t len, size_t anchor) {
    for (const char *q = p + anchor; q < end;) {
        const char *hit = memchr(q, needle[anchor], (size_t)(end - q));
        if (!hit) return NULL;
        const char *start = hit - anchor;
        if ((size_t)(end - start) >= len && memcmp(start, needle, len) == 0) return start;
        q = hit + 1;
    }
    return NULL;
}

// The unsigned integer at p (the gateway's time_ms and missed are plain integers).
static uint64_t read_uint(const char *p, const char *end) {
    uint64_t v = 0;
    for (; p < end && *p >= '0' && *p <= '9'; ++p)
        v = v * 10 + (uint64_t)(*p - '0');
    return v;
}

// Every event in one text message (an event, a gap, or a batch of them).
static void on_message(struct client *c, const char *p, size_t n) {
    const double t = now_ms();
    const char *end = p + n;
    for (const char *q = p; (q = find(q, end, "\"type\":\"", 8, 2)) != NULL;) {
        q += 8;
        if ((size_t)(end - q) >= 6 && memcmp(q, "event\"", 6) == 0) {
            ++c->base.events;
            const char *tm = find(q, end, "\"time_ms\":", 10, 5);
            if (tm) record_latency((double)read_uint(tm + 10, end), t);
        } else if ((size_t)(end - q) >= 4 && memcmp(q, "gap\"", 4) == 0) {
            const char *m = find(q, end, "\"missed\":", 9, 1);
            if (m) {
                const uint64_t missed = read_uint(m + 9, end);
                missed_total += missed;
                c->base.missed += missed;
            }
        }
    }
}

// Parses whole frames from the client's buffer; returns 0 when the server closed.
static int on_readable(struct connection *connection) {
    struct client *c = (struct client *)connection;
    if (!read_available(c->base.fd, &c->base.in)) return 0;
    const size_t len = c->base.in.len;
    size_t at = 0;
    while (len - at >= 2) {
        const uint8_t *f = (const uint8_t *)c->base.in.data + at;
        uint64_t n = f[1] & 0x7f;
        size_t off = 2;
        if (n == 126) {
            if (len - at < 4) break;
            n = ((uint64_t)f[2] << 8) | f[3];
            off = 4;
        } else if (n == 127) {
            if (len - at < 10) break;
            n = 0;
            for (int i = 0; i < 8; ++i)
                n = (n << 8) | f[2 + i];
            off = 10;
        }
        if (len - at < off + n) break;
        const int opcode = f[0] & 0x0f, fin = f[0] & 0x80;
        if (opcode == 0x8) return 0;  // close
        if (opcode == 0x9) {          // ping: answer with an empty masked pong
            const uint8_t pong[6] = {0x8A, 0x80, 0, 0, 0, 0};
            send_all(c->base.fd, pong, sizeof pong);
        } else if (opcode == 0x1 && fin) {
            on_message(c, (const char *)f + off, (size_t)n);
        } else if (opcode == 0x1 || (opcode == 0x0 && c->in_text)) {  // a fragment
            if (opcode == 0x1) c->message_len = 0;
            if (c->message_cap < c->message_len + n) {
                c->message_cap = (c->message_len + n) * 2;
                c->message = realloc(c->message, c->message_cap);
                if (!c->message) die("realloc");
            }
            memcpy(c->message + c->message_len, f + off, (size_t)n);
            c->message_len += (size_t)n;
            c->in_text = !fin;
            if (fin) on_message(c, c->message, c->message_len);
        }
        at += off + (size_t)n;
    }
    consume(&c->base.in, at);
    return 1;
}

int main(int argc, char **argv) {
    if (argc != 5) {
        fprintf(stderr, "usage: fanout_client PORT CLIENTS BATCH_MS TOPIC\n");
        return 2;
    }
    program_name = "fanout_client";
    const int port = atoi(argv[1]), count = atoi(argv[2]), batch_ms = atoi(argv[3]);
    if (count <= 0 || count > max_clients) die("CLIENTS must be 1..1024");
    stop_on_signals();
    struct client *clients = calloc((size_t)count, sizeof *clients);
    int ep = epoll_create1(0);
    if (!clients || ep < 0) die("setup");
    char subscribe[128];
    snprintf(subscribe, sizeof subscribe, "{\"op\":\"subscribe\",\"topics\":[\"%s\"]}", argv[4]);
    for (int i = 0; i < count; ++i) {
        clients[i].base.fd = connect_ws(port, batch_ms);
        send_text(clients[i].base.fd, subscribe);
        watch(ep, &clients[i].base, i);
    }
    start_ms = now_ms();
    printf("subscribed\n");
    fflush(stdout);
    serve(ep, clients, sizeof *clients, on_readable);
    print_counts(clients, sizeof *clients, count);
    printf("missed %llu ", (unsigned long long)missed_total);
    print_latencies();
    return 0;
}
