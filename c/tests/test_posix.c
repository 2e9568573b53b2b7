/* The POSIX host layer on a pseudo-terminal: rates, request/answer, timeouts, errors. */
#define _XOPEN_SOURCE 700
#define _DEFAULT_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "nurimc_posix.h"

static int open_master(char *slave_path, size_t size) {
    int master = posix_openpt(O_RDWR | O_NOCTTY);
    if (master < 0 || grantpt(master) != 0 || unlockpt(master) != 0) return -1;
    strncpy(slave_path, ptsname(master), size - 1);
    slave_path[size - 1] = '\0';
    return master;
}

#if defined(__linux__)
/* The rate the host set, as the pty master sees it: struct termios2 c_ospeed at byte 40. */
static uint32_t master_sees_baud(int master) {
    unsigned char raw[44];
    uint32_t ospeed;
    if (ioctl(master, 0x802C542AUL, raw) != 0) return 0;
    memcpy(&ospeed, raw + 40, sizeof ospeed);
    return ospeed;
}
#endif

static void test_every_rate(void) {
    char path[128];
    int master = open_master(path, sizeof path);
    int i;
    CHECK(master >= 0);
    for (i = 0; i < (int)NURIMC_BAUD_RATE_COUNT; i++) {
        nurimc_port port;
        CHECK_EQ(nurimc_port_open(&port, path, nurimc_baud_rates[i]), NURIMC_OK);
        CHECK_EQ(port.baud, nurimc_baud_rates[i]);
#if defined(__linux__)
        CHECK_EQ(master_sees_baud(master), nurimc_baud_rates[i]);
#endif
        nurimc_port_close(&port);
        nurimc_port_close(&port); /* twice is harmless */
    }
    close(master);
}

static void test_open_errors(void) {
    nurimc_port port;
    char path[128];
    int master = open_master(path, sizeof path);
    CHECK_EQ(nurimc_port_open(&port, path, 12345), NURIMC_E_BAUD);
    CHECK_EQ(port.fd, -1);
    errno = 0;
    CHECK_EQ(nurimc_port_open(&port, "/nonexistent/tty", 9600), NURIMC_E_IO);
    CHECK_EQ(errno, ENOENT);
    CHECK_EQ(nurimc_port_open(&port, path, 115200), NURIMC_OK);
    CHECK_EQ(nurimc_port_set_baud(&port, 14400), NURIMC_OK);
    CHECK_EQ(port.baud, 14400);
    CHECK_EQ(nurimc_port_set_baud(&port, 14401), NURIMC_E_BAUD);
    CHECK_EQ(port.baud, 14400);
    nurimc_port_close(&port);
    close(master);
}

static void test_timeout_formula(void) {
    nurimc_bus bus;
    memset(&bus, 0, sizeof bus);
    bus.port.baud = 9600;
    bus.adapter_latency_us = 10000;
    bus.margin_us = 3000;
    bus.response_time_us = 25400;
    /* ping: 6 + 6 bytes = 120 bits at 9600 bps = 12500 us; + 25400 + 2 x 10000 + 3000 */
    CHECK_EQ(nurimc_bus_answer_timeout_us(&bus, NURIMC_MSG_REQUEST_PING), 60900);
    /* position: 6 + 12 bytes = 18750 us at 9600 */
    CHECK_EQ(nurimc_bus_answer_timeout_us(&bus, NURIMC_MSG_REQUEST_POSITION), 67150);
    bus.port.baud = 110; /* the slowest rate: 120 bits take 1.09 s */
    CHECK_EQ(nurimc_bus_answer_timeout_us(&bus, NURIMC_MSG_REQUEST_PING), 1090910 + 48400);
}

typedef struct responder {
    int master;
    uint8_t reply[64];
    size_t reply_length;
    uint8_t got[NURIMC_MAX_FRAME_LENGTH];
    size_t got_length;
} responder;

/* Read one 6-byte request from the master side, then write the prepared reply. */
static void *respond(void *arg) {
    responder *r = arg;
    while (r->got_length < 6) {
        struct pollfd pfd;
        ssize_t n;
        pfd.fd = r->master;
        pfd.events = POLLIN;
        if (poll(&pfd, 1, 5000) <= 0) return NULL;
        n = read(r->master, r->got + r->got_length, 6 - r->got_length);
        if (n <= 0) return NULL;
        r->got_length += (size_t)n;
    }
    if (write(r->master, r->reply, r->reply_length) != (ssize_t)r->reply_length) return NULL;
    return NULL;
}

static size_t put_frame(uint8_t *out, nurimc_message msg) {
    size_t length = 0;
    nurimc_encode(&msg, out, NURIMC_MAX_FRAME_LENGTH, &length, NULL);
    return length;
}

static void test_request_answer(void) {
    char path[128];
    responder r;
    pthread_t thread;
    nurimc_bus bus;
    nurimc_message answer;
    nurimc_message feedback = nurimc_message_init(NURIMC_MSG_POSITION_FEEDBACK, 3);
    memset(&r, 0, sizeof r);
    r.master = open_master(path, sizeof path);
    /* the echo of our request, noise, another controller's answer, then ours */
    r.reply_length += put_frame(r.reply, nurimc_message_init(NURIMC_MSG_REQUEST_POSITION, 3));
    r.reply[r.reply_length++] = 0x00;
    r.reply_length += put_frame(r.reply + r.reply_length, nurimc_message_init(NURIMC_MSG_POSITION_FEEDBACK, 4));
    feedback.u.position_feedback.position = 9000;
    feedback.u.position_feedback.speed = 120;
    r.reply_length += put_frame(r.reply + r.reply_length, feedback);
    CHECK_EQ(nurimc_bus_open(&bus, path, 250000), NURIMC_OK);
    bus.response_time_us = 100;
    bus.adapter_latency_us = 1000000; /* generous: the test must not depend on scheduling */
    CHECK_EQ(pthread_create(&thread, NULL, respond, &r), 0);
    CHECK_EQ(nurimc_bus_query(&bus, NURIMC_MSG_REQUEST_POSITION, 3, &answer), NURIMC_OK);
    pthread_join(thread, NULL);
    CHECK_EQ(r.got_length, 6);
    CHECK_EQ(r.got[5], 0xA1);
    CHECK_EQ(r.got[2], 3);
    CHECK_EQ(answer.type, NURIMC_MSG_POSITION_FEEDBACK);
    CHECK_EQ(answer.id, 3);
    CHECK_EQ(answer.u.position_feedback.position, 9000);
    CHECK_EQ(answer.u.position_feedback.speed, 120);
    CHECK_EQ(bus.ignored_frames, 2);
    nurimc_bus_close(&bus);
    close(r.master);
}

static uint64_t now_us(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static void test_timeout_and_misuse(void) {
    char path[128];
    int master = open_master(path, sizeof path);
    nurimc_bus bus;
    nurimc_message answer, command = nurimc_message_init(NURIMC_MSG_SET_CONTROL, 1);
    uint64_t start, elapsed;
    uint8_t sent[16];
    int bad = 0;
    CHECK_EQ(nurimc_bus_open(&bus, path, 1000000), NURIMC_OK);
    bus.retries = 1;
    start = now_us();
    CHECK_EQ(nurimc_bus_query(&bus, NURIMC_MSG_REQUEST_PING, 1, &answer), NURIMC_E_TIMEOUT);
    elapsed = now_us() - start;
    CHECK(elapsed >= 2u * nurimc_bus_answer_timeout_us(&bus, NURIMC_MSG_REQUEST_PING));
    CHECK(elapsed < 10000000u); /* it gave up; it did not hang */
    CHECK_EQ(read(master, sent, sizeof sent), 12); /* the request went out, and once more */
    CHECK_EQ(sent[11], 0xA0);
    /* a command is sent, never awaited; request() refuses it; requests are never broadcast */
    CHECK_EQ(nurimc_bus_request(&bus, &command, &answer), NURIMC_E_ARGUMENT);
    CHECK_EQ(nurimc_bus_send(&bus, &command, &bad), NURIMC_OK);
    CHECK_EQ(read(master, sent, sizeof sent), 7);
    CHECK_EQ(sent[5], 0x0C);
    CHECK_EQ(nurimc_bus_query(&bus, NURIMC_MSG_REQUEST_PING, NURIMC_BROADCAST_ID, &answer), NURIMC_E_RANGE);
    command.u.set_control.control = 2;
    CHECK_EQ(nurimc_bus_send(&bus, &command, &bad), NURIMC_E_RANGE);
    CHECK_EQ(bad, 0);
    nurimc_bus_close(&bus);
    close(master);
}

int main(void) {
    test_every_rate();
    test_open_errors();
    test_timeout_formula();
    test_request_answer();
    test_timeout_and_misuse();
    return check_report("test_posix");
}
