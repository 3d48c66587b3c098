// Many MQTT subscribers of one broker in one process (epoll), for the fan-out benchmark's MQTT side
// (bench/fanout.py): the gateway's report batches through its MQTT bridge, and the peer run where
// mosquitto alone fans the same frames out.
//
//   mqtt_fanout_client PORT CLIENTS TOPIC_FILTER
//
// Opens CLIENTS MQTT 3.1.1 connections to 127.0.0.1:PORT (clean session, QoS 0), subscribes each to
// TOPIC_FILTER, prints "subscribed", then reads until SIGTERM. A message's payload is a report batch
// ({"frames":[...],"missed":N,...}, one frame or many): every frame ("controller_seq") is counted and
// its latency taken from its "time" (the gateway's clock when the frame arrived, millisecond
// precision) to when it is read here; "missed" is summed. At the end it prints one line of "key value"
// pairs: clients, closed, events (frames, all clients), min_events and max_events (per client),
// messages, missed, p50_ms, p99_ms, max_ms.
#define _GNU_SOURCE
#include <signal.h>
#include <sys/epoll.h>

#include "fanout_common.h"

enum { max_clients = 1024 };

struct client {
    struct connection base;  // first: serve() and print_counts() see it
    uint64_t messages;
};

static uint64_t missed_total;

// The remaining-length field of a packet: bytes used, 0 when more bytes are needed, -1 when malformed.
static int remaining_length(const unsigned char *p, size_t n, size_t *value) {
    size_t v = 0;
    for (int i = 0; i < 4; ++i) {
        if ((size_t)i >= n) return 0;
        v |= (size_t)(p[i] & 0x7f) << (7 * i);
        if (!(p[i] & 0x80)) {
            *value = v;
            return i + 1;
        }
    }
    return -1;
}

static size_t put_string(unsigned char *p, const char *s) {
    const size_t n = strlen(s);
    p[0] = (unsigned char)(n >> 8);
    p[1] = (unsigned char)n;
    memcpy(p + 2, s, n);
    return n + 2;
}

// Reads one whole packet (blocking, during the handshake) and returns its type.
static int read_packet(int fd) {
    unsigned char head[5];
    if (read(fd, head, 2) != 2) die("read a packet");
    size_t n = head[1] & 0x7f;
    if (head[1] & 0x80) die("a handshake packet too long");
    unsigned char body[256];
    if (n > sizeof body || (n > 0 && read(fd, body, n) != (ssize_t)n)) die("read a packet's body");
    return head[0] >> 4;
}

static int connect_mqtt(int port, int index, const char *filter) {
    int fd = connect_loopback(port);
    unsigned char p[512];
    char id[32];
    snprintf(id, sizeof id, "fanout-%d", index);
    // CONNECT: "MQTT", level 4, clean session, keep-alive 600 s, the client id.
    size_t n = 2;
    n += put_string(p + n, "MQTT");
    p[n++] = 4;
    p[n++] = 0x02;
    p[n++] = 0x02;
    p[n++] = 0x58;
    n += put_string(p + n, id);
    p[0] = 0x10;
    p[1] = (unsigned char)(n - 2);
    send_all(fd, p, n);
    if (read_packet(fd) != 2) die("no CONNACK");
    // SUBSCRIBE packet 1, the filter at QoS 0.
    n = 2;
    p[n++] = 0;
    p[n++] = 1;
    n += put_string(p + n, filter);
    p[n++] = 0;
    p[0] = 0x82;
    p[1] = (unsigned char)(n - 2);
    send_all(fd, p, n);
    if (read_packet(fd) != 9) die("no SUBACK");
    return fd;
}

// "2026-12-03T01:02:03.456Z" -> milliseconds since the epoch, or -1. The date and time to the second
// are parsed once per second of frames (timegm is far dearer than the frames' other handling).
static double parse_time_ms(const char *p, const char *end) {
    static char cached[19];
    static double cached_ms = -1;
    if (end - p < 24 || p[19] != '.' || p[23] != 'Z') return -1;
    if (cached_ms < 0 || memcmp(cached, p, 19) != 0) {
        struct tm tm = {0};
        if (sscanf(p, "%4d-%2d-%2dT%2d:%2d:%2d", &tm.tm_year, &tm.tm_mon, &tm.tm_mday, &tm.tm_hour, &tm.tm_min,
                   &tm.tm_sec) != 6)
            return -1;
        tm.tm_year -= 1900;
        tm.tm_mon -= 1;
        memcpy(cached, p, 19);
        cached_ms = (double)timegm(&tm) * 1e3;
    }
    return cached_ms + (p[20] - '0') * 100 + (p[21] - '0') * 10 + (p[22] - '0');
}

static void on_publish(struct client *c, const char *p, size_t n) {
    const double t = now_ms();
    const char *end = p + n;
    ++c->messages;
    for (const char *q = p; (q = memmem(q, (size_t)(end - q), "\"controller_seq\":", 17)) != NULL;) {
        q += 17;
        ++c->base.events;
        const char *tm = memmem(q, (size_t)(end - q), "\"time\":\"", 8);
        if (tm) {
            const double sent = parse_time_ms(tm + 8, end);
            if (sent >= 0) record_latency(sent, t);
        }
    }
    const char *m = memmem(p, n, "\"missed\":", 9);
    if (m) missed_total += strtoull(m + 9, NULL, 10);
}

// Parses whole packets from the client's buffer; returns 0 when the broker closed.
static int on_readable(struct connection *connection) {
    struct client *c = (struct client *)connection;
    if (!read_available(c->base.fd, &c->base.in)) return 0;
    const size_t len = c->base.in.len;
    size_t at = 0;
    while (len - at >= 2) {
        const unsigned char *f = (const unsigned char *)c->base.in.data + at;
        size_t body = 0;
        const int used = remaining_length(f + 1, len - at - 1, &body);
        if (used < 0) return 0;
        if (used == 0 || len - at < 1 + (size_t)used + body) break;
        const unsigned char *b = f + 1 + used;
        if ((f[0] >> 4) == 3 && body >= 2) {  // PUBLISH, QoS 0: topic, then the payload
            const size_t topic = ((size_t)b[0] << 8) | b[1];
            if (2 + topic <= body) on_publish(c, (const char *)b + 2 + topic, body - 2 - topic);
        }
        at += 1 + (size_t)used + body;
    }
    consume(&c->base.in, at);
    return 1;
}

int main(int argc, char **argv) {
    program_name = "mqtt_fanout_client";
    if (argc != 4) {
        fprintf(stderr, "usage: mqtt_fanout_client PORT CLIENTS TOPIC_FILTER\n");
        return 2;
    }
    const int port = atoi(argv[1]), count = atoi(argv[2]);
    if (count <= 0 || count > max_clients) die("CLIENTS must be 1..1024");
    if (strlen(argv[3]) > 200) die("TOPIC_FILTER too long");
    stop_on_signals();
    struct client *clients = calloc((size_t)count, sizeof *clients);
    int ep = epoll_create1(0);
    if (!clients || ep < 0) die("setup");
    for (int i = 0; i < count; ++i) {
        clients[i].base.fd = connect_mqtt(port, i, argv[3]);
        watch(ep, &clients[i].base, i);
    }
    start_ms = now_ms();
    printf("subscribed\n");
    fflush(stdout);
    serve(ep, clients, sizeof *clients, on_readable);
    uint64_t messages = 0;
    for (int i = 0; i < count; ++i)
        messages += clients[i].messages;
    print_counts(clients, sizeof *clients, count);
    printf("messages %llu missed %llu ", (unsigned long long)messages, (unsigned long long)missed_total);
    print_latencies();
    return 0;
}
