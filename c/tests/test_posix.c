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
#include "nurimc_settings.h"

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

/* One program per port: a second open (another program, or this one again) is refused with
 * NURIMC_E_BUSY while the first holds it, and succeeds once it is closed. */
static void test_port_is_locked(void) {
    nurimc_port first, second;
    char path[128];
    int master = open_master(path, sizeof path);
    CHECK(master >= 0);
    CHECK_EQ(nurimc_port_open(&first, path, 9600), NURIMC_OK);
    errno = 0;
    CHECK_EQ(nurimc_port_open(&second, path, 9600), NURIMC_E_BUSY);
    CHECK_EQ(errno, EBUSY);
    CHECK_EQ(second.fd, -1);
    CHECK(strstr(nurimc_status_text(NURIMC_E_BUSY), "another program") != NULL);
    CHECK(strcmp(nurimc_status_name(NURIMC_E_BUSY), "busy") == 0);
    nurimc_port_close(&first);
    CHECK_EQ(nurimc_port_open(&second, path, 9600), NURIMC_OK);
    nurimc_port_close(&second);
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
    CHECK(elapsed < 10000000u);                    /* it gave up; it did not hang */
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

/* Drain what the host wrote to the master side (so the pty never fills). */
static void drain(int master) {
    uint8_t junk[256];
    struct pollfd pfd;
    pfd.fd = master;
    pfd.events = POLLIN;
    while (poll(&pfd, 1, 0) > 0 && read(master, junk, sizeof junk) > 0) {}
}

static nurimc_message gains(uint8_t id) {
    nurimc_message msg = nurimc_message_init(NURIMC_MSG_SET_POSITION_GAINS, id);
    msg.u.set_position_gains.kp = 10;
    msg.u.set_position_gains.rated_current = 30;
    return msg;
}

static void test_busy_rule_from_spec(void) {
    CHECK(nurimc_writes_eeprom(NURIMC_MSG_SET_CONTROL));
    CHECK(nurimc_writes_eeprom(NURIMC_MSG_SET_ID));
    CHECK(nurimc_writes_eeprom(NURIMC_MSG_FACTORY_RESET));
    CHECK(!nurimc_writes_eeprom(NURIMC_MSG_POSITION_SPEED));
    CHECK(!nurimc_writes_eeprom(NURIMC_MSG_RESET_POSITION));
    CHECK(!nurimc_writes_eeprom(NURIMC_MSG_REQUEST_PING));
    CHECK_EQ(nurimc_profile_busy_window_us(NURIMC_PROFILE_MC), 300000);
    CHECK_EQ(nurimc_profile_by_name("blmc-h"), NURIMC_PROFILE_BLMC_H);
    CHECK_EQ(nurimc_profile_by_name("warp"), -1);
    CHECK_EQ(NURIMC_DEFAULT_ADAPTER_LATENCY_US, 2000); /* spec/host.json, as Python and TypeScript */
}

static void test_busy_windows_configurable(void) {
    char path[128];
    int master = open_master(path, sizeof path);
    nurimc_bus bus;
    CHECK_EQ(nurimc_bus_open(&bus, path, 115200), NURIMC_OK);
    CHECK_EQ(nurimc_bus_busy_window_us(&bus, 4), 300000); /* profile mc */
    CHECK_EQ(nurimc_bus_set_product(&bus, 4, NURIMC_PROFILE_BLMC_H), NURIMC_OK);
    CHECK_EQ(nurimc_bus_busy_window_us(&bus, 4), nurimc_profile_busy_window_us(NURIMC_PROFILE_BLMC_H));
    CHECK_EQ(nurimc_bus_set_product(&bus, 255, NURIMC_PROFILE_MC), NURIMC_E_ARGUMENT);
    CHECK_EQ(nurimc_bus_set_product(&bus, 1, NURIMC_PROFILE_COUNT), NURIMC_E_ARGUMENT);
    bus.busy_window_us = 120000;
    bus.busy_windows_us[4] = 80000;
    CHECK_EQ(nurimc_bus_busy_window_us(&bus, 4), 80000);  /* per ID first */
    CHECK_EQ(nurimc_bus_busy_window_us(&bus, 5), 120000); /* then the bus */
    bus.busy_windows_us[9] = 200000;
    CHECK_EQ(nurimc_bus_busy_window_us(&bus, NURIMC_BROADCAST_ID), 200000); /* broadcast: the largest */
    bus.busy_windows_us[9] = 0;
    CHECK_EQ(nurimc_bus_busy_window_us(&bus, 9), 0);
    CHECK_EQ(nurimc_bus_busy_window_us(&bus, NURIMC_BROADCAST_ID), 120000);
    nurimc_bus_close(&bus);
    close(master);
}

static void test_busy_window_holds_frames(void) {
    char path[128];
    int master = open_master(path, sizeof path);
    nurimc_bus bus;
    nurimc_message motion = nurimc_message_init(NURIMC_MSG_POSITION_SPEED, 1), set_id, reset;
    uint64_t start, now;
    motion.u.position_speed.speed = 10;
    CHECK_EQ(nurimc_bus_open(&bus, path, 1000000), NURIMC_OK);
    bus.busy_window_us = 40000;
    /* motion never makes an ID busy */
    CHECK_EQ(nurimc_bus_send(&bus, &motion, NULL), NURIMC_OK);
    CHECK_EQ(nurimc_bus_busy_until_us(&bus, 1), 0);
    /* a settings write holds the next frame to that ID until its window ended ... */
    start = now_us();
    {
        nurimc_message g = gains(1);
        CHECK_EQ(nurimc_bus_send(&bus, &g, NULL), NURIMC_OK);
    }
    CHECK(nurimc_bus_busy_until_us(&bus, 1) >= start + 40000u);
    CHECK_EQ(nurimc_bus_busy_until_us(&bus, 2), 0);
    /* ... but not frames to other IDs */
    motion.id = 2;
    CHECK_EQ(nurimc_bus_send(&bus, &motion, NULL), NURIMC_OK);
    CHECK_EQ(bus.busy_waits, 0);
    motion.id = 1;
    CHECK_EQ(nurimc_bus_send(&bus, &motion, NULL), NURIMC_OK);
    now = now_us();
    CHECK(now - start >= 40000u);
    CHECK_EQ(bus.busy_waits, 1);
    /* set_id: the old and the new ID; factory_reset: ID 0 too */
    set_id = nurimc_message_init(NURIMC_MSG_SET_ID, 5);
    set_id.u.set_id.new_id = 6;
    reset = nurimc_message_init(NURIMC_MSG_FACTORY_RESET, 7);
    CHECK_EQ(nurimc_bus_send(&bus, &set_id, NULL), NURIMC_OK);
    CHECK_EQ(nurimc_bus_send(&bus, &reset, NULL), NURIMC_OK);
    now = now_us();
    CHECK(nurimc_bus_busy_until_us(&bus, 5) > now + 30000u);
    CHECK(nurimc_bus_busy_until_us(&bus, 6) > now + 30000u);
    CHECK(nurimc_bus_busy_until_us(&bus, 7) > now + 30000u);
    CHECK(nurimc_bus_busy_until_us(&bus, 0) > now + 30000u);
    CHECK_EQ(nurimc_bus_busy_until_us(&bus, 8), 0);
    /* a broadcast frame waits for every ID; a broadcast write makes every ID busy */
    {
        nurimc_message all = nurimc_message_init(NURIMC_MSG_SET_CONTROL, NURIMC_BROADCAST_ID);
        uint64_t until = nurimc_bus_busy_until_us(&bus, NURIMC_BROADCAST_ID);
        CHECK_EQ(nurimc_bus_send(&bus, &all, NULL), NURIMC_OK);
        CHECK(now_us() >= until);
        CHECK(nurimc_bus_busy_until_us(&bus, 200) >= until + 40000u);
    }
    drain(master);
    nurimc_bus_close(&bus);
    close(master);
}

static void test_silence_after_a_write_is_busy(void) {
    char path[128];
    int master = open_master(path, sizeof path);
    nurimc_bus bus;
    nurimc_message answer, ratio = nurimc_message_init(NURIMC_MSG_SET_RATIO, 3);
    ratio.u.set_ratio.ratio = 10;
    CHECK_EQ(nurimc_bus_open(&bus, path, 1000000), NURIMC_OK);
    bus.busy_window_us = 30000;
    bus.retries = 0;
    bus.response_time_us = 100;
    CHECK_EQ(nurimc_bus_send(&bus, &ratio, NULL), NURIMC_OK);
    CHECK_EQ(nurimc_bus_query(&bus, NURIMC_MSG_REQUEST_PING, 3, &answer), NURIMC_E_TIMEOUT);
    CHECK_EQ(bus.timeout_was_busy, 1); /* busy writing its settings, not missing */
    CHECK_EQ(nurimc_bus_query(&bus, NURIMC_MSG_REQUEST_PING, 4, &answer), NURIMC_E_TIMEOUT);
    CHECK_EQ(bus.timeout_was_busy, 0); /* never written to: silence is silence */
    drain(master);
    nurimc_bus_close(&bus);
    close(master);
}

static void test_settings_map(void) {
    size_t count = 0;
    const nurimc_setting *all = nurimc_settings(&count), *ratio = nurimc_setting_by_name("ratio");
    const nurimc_setting *kp = nurimc_setting_by_name("position-kp"), *firmware = nurimc_setting_by_name("firmware");
    CHECK_EQ(count, NURIMC_SETTING_COUNT);
    CHECK(all != NULL && count >= 16);
    CHECK(ratio != NULL && kp != NULL && firmware != NULL);
    CHECK(nurimc_setting_by_name("warp") == NULL);
    if (ratio == NULL || kp == NULL || firmware == NULL) return;
    CHECK_EQ(ratio->command, NURIMC_MSG_SET_RATIO);
    CHECK_EQ(ratio->request, NURIMC_MSG_REQUEST_RATIO);
    CHECK_EQ(ratio->scale_num, 1);
    CHECK_EQ(ratio->scale_den, 10);
    CHECK_EQ(ratio->input, NURIMC_INPUT_QUANTIZE);
    CHECK_EQ(kp->command, NURIMC_MSG_SET_POSITION_GAINS);
    CHECK_EQ(kp->answer, NURIMC_MSG_POSITION_GAINS);
    CHECK_EQ(kp->min, 1);
    CHECK_EQ(kp->input, NURIMC_INPUT_INTEGER);
    CHECK_EQ(firmware->command, -1); /* read-only */
    /* every setting's field exists in its answer (and command) */
    for (; count > 0; count--, all++) {
        CHECK(nurimc_field_index(all->answer, all->field) >= 0);
        CHECK(all->command < 0 || nurimc_field_index((nurimc_message_type)all->command, all->field) >= 0);
    }
}

int main(void) {
    test_every_rate();
    test_open_errors();
    test_port_is_locked();
    test_timeout_formula();
    test_request_answer();
    test_timeout_and_misuse();
    test_busy_rule_from_spec();
    test_busy_windows_configurable();
    test_busy_window_holds_frames();
    test_silence_after_a_write_is_busy();
    test_settings_map();
    return check_report("test_posix");
}
