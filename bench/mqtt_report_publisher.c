// The fan-out benchmark's peer run (bench/fanout.py --peer): report frames published straight to an
// MQTT broker, one message per frame, as a lab without the gateway would publish them, so that
// mosquitto's cost per delivered message can be set beside the gateway's per delivered frame.
//
//   mqtt_report_publisher PORT COUNT RATE_HZ PREFIX
//
// Connects to 127.0.0.1:PORT (MQTT 3.1.1), prints "ready", and waits. SIGUSR1 starts the frames: every
// 1/RATE_HZ s, one QoS 0 message to each of PREFIX/controllers/c0/reports .. c<COUNT-1>: the payload
// is the gateway's MQTT report batch with one frame, with its own clock as the frame's "time", so the
// subscribers (bench/mqtt_fanout_client.c) read both alike. SIGTERM stops and prints "written W
// refused 0 late L" (ticks later than one period: the publisher, or the broker, fell behind).
#define _GNU_SOURCE
#include <signal.h>

#include "fanout_common.h"
#include "paced_run.h"


static void format_time(char *out, size_t size) {
    struct timespec t;
    clock_gettime(CLOCK_REALTIME, &t);
    struct tm tm;
    gmtime_r(&t.tv_sec, &tm);
    snprintf(out, size, "%04d-%02d-%02dT%02d:%02d:%02d.%03ldZ", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday,
             tm.tm_hour, tm.tm_min, tm.tm_sec, t.tv_nsec / 1000000);
}

// A PUBLISH packet (QoS 0) into out; returns its size.
static size_t publish_packet(unsigned char *out, const char *topic, const char *payload) {
    const size_t t = strlen(topic), p = strlen(payload), body = 2 + t + p;
    size_t n = 0;
    out[n++] = 0x30;
    size_t v = body;
    do {
        unsigned char b = v & 0x7f;
        v >>= 7;
        out[n++] = v ? (b | 0x80) : b;
    } while (v);
    out[n++] = (unsigned char)(t >> 8);
    out[n++] = (unsigned char)t;
    memcpy(out + n, topic, t);
    memcpy(out + n + t, payload, p);
    return n + t + p;
}

int main(int argc, char **argv) {
    program_name = "mqtt_report_publisher";
    if (argc != 5) {
        fprintf(stderr, "usage: mqtt_report_publisher PORT COUNT RATE_HZ PREFIX\n");
        return 2;
    }
    const int port = atoi(argv[1]), count = atoi(argv[2]);
    const double rate = atof(argv[3]);
    if (count <= 0 || count > 1024 || rate <= 0 || strlen(argv[4]) > 100) {
        fprintf(stderr, "mqtt_report_publisher: COUNT 1..1024, RATE_HZ > 0, PREFIX up to 100 characters\n");
        return 2;
    }
    int fd = connect_loopback(port);
    unsigned char connect_packet[] = {0x10, 20, 0, 4, 'M', 'Q', 'T', 'T', 4, 0x02, 0x02, 0x58, 0, 8,
                                      'r',  'e', 'p', 'o', 'r', 't', 'e', 'r'};
    send_all(fd, connect_packet, sizeof connect_packet);
    unsigned char connack[4];
    if (read(fd, connack, 4) != 4 || connack[0] != 0x20 || connack[3] != 0) die("no CONNACK");
    printf("ready\n");
    fflush(stdout);
    wait_for_start();

    struct ticker ticker;
    ticker_start(&ticker, rate);
    uint64_t written = 0;
    long n = 0;
    unsigned char *packets = malloc((size_t)count * 1024);
    if (!packets) die("malloc");
    while (!stopping) {
        ++n;
        char time[64], topic[160], payload[768];
        format_time(time, sizeof time);
        size_t size = 0;
        for (int i = 0; i < count; ++i) {
            snprintf(topic, sizeof topic, "%s/controllers/c%d/reports", argv[4], i);
            snprintf(payload, sizeof payload,
                     "{\"type\":\"reports\",\"controller\":\"c%d\",\"frames\":[{\"axes\":["
                     "{\"axis\":\"X\",\"counts\":%ld,\"position_um\":%.1f},"
                     "{\"axis\":\"Y\",\"counts\":%ld,\"position_um\":%.1f},"
                     "{\"axis\":\"Z\",\"counts\":%ld,\"position_um\":%.1f}],"
                     "\"bytes_skipped\":0,\"controller_seq\":%ld,\"id\":\"c%d\",\"time\":\"%s\"}],"
                     "\"from\":%ld,\"to\":%ld,\"missed\":0,\"time\":\"%s\"}",
                     i, n, n * 0.1, 2 * n, n * 0.2, 3 * n, n * 0.3, n, i, time, n, n, time);
            size += publish_packet(packets + size, topic, payload);
        }
        send_all(fd, packets, size);  // blocks while the broker does not read: counted as late ticks
        written += (uint64_t)count;
        ticker_wait(&ticker);
    }
    printf("written %llu refused 0 late %llu\n", (unsigned long long)written, (unsigned long long)ticker.late);
    return 0;
}
