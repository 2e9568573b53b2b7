/*
 * The host layer against the simulator (nurimc.sim) over a pseudo-terminal: ping, status,
 * move (the feedback position changes), a setting round trip. Run by sim_test.py.
 * Usage: test_sim PORT BAUD
 */
#define _POSIX_C_SOURCE 200809L
#include <stdlib.h>
#include <time.h>

#include "check.h"
#include "nurimc_posix.h"

static uint64_t now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u;
}

static nurimc_status query(nurimc_bus *bus, nurimc_message_type type, uint8_t id, nurimc_message *answer) {
    nurimc_status status = nurimc_bus_query(bus, type, id, answer);
    if (status != NURIMC_OK)
        fprintf(stderr, "%s to ID %u: %s\n", nurimc_spec(type)->name, id, nurimc_status_text(status));
    return status;
}

int main(int argc, char **argv) {
    nurimc_bus bus;
    nurimc_message a, cmd;
    uint16_t start_position;
    uint64_t deadline;
    int moved = 0;
    if (argc != 3) {
        fputs("usage: test_sim PORT BAUD\n", stderr);
        return 2;
    }
    CHECK_EQ(nurimc_bus_open(&bus, argv[1], (uint32_t)atol(argv[2])), NURIMC_OK);
    bus.adapter_latency_us = 200000; /* a loaded CI machine schedules the simulator late */

    /* ping: IDs 0 and 1 answer, 7 does not */
    CHECK_EQ(query(&bus, NURIMC_MSG_REQUEST_PING, 0, &a), NURIMC_OK);
    CHECK_EQ(a.type, NURIMC_MSG_PING);
    CHECK_EQ(query(&bus, NURIMC_MSG_REQUEST_PING, 1, &a), NURIMC_OK);
    CHECK_EQ(a.id, 1);
    CHECK_EQ(nurimc_bus_query(&bus, NURIMC_MSG_REQUEST_PING, 7, &a), NURIMC_E_TIMEOUT);

    /* status: position, speed, settings */
    CHECK_EQ(query(&bus, NURIMC_MSG_REQUEST_POSITION, 1, &a), NURIMC_OK);
    CHECK_EQ(a.type, NURIMC_MSG_POSITION_FEEDBACK);
    start_position = a.u.position_feedback.position;
    CHECK_EQ(query(&bus, NURIMC_MSG_REQUEST_SPEED, 1, &a), NURIMC_OK);
    CHECK_EQ(a.type, NURIMC_MSG_SPEED_FEEDBACK);
    CHECK_EQ(query(&bus, NURIMC_MSG_REQUEST_RESPONSE_TIME, 1, &a), NURIMC_OK);
    CHECK_EQ(a.u.response_time.response_time, NURIMC_DEFAULT_RESPONSE_TIME);
    CHECK_EQ(query(&bus, NURIMC_MSG_REQUEST_FIRMWARE, 1, &a), NURIMC_OK);
    CHECK_EQ(a.type, NURIMC_MSG_FIRMWARE);

    /* move: 90 degrees at 300 rpm; the feedback position changes within a few seconds */
    cmd = nurimc_message_init(NURIMC_MSG_POSITION_SPEED, 1);
    cmd.u.position_speed.direction = 1;
    cmd.u.position_speed.position = (uint16_t)(start_position == 9000 ? 18000 : 9000);
    cmd.u.position_speed.speed = 3000;
    CHECK_EQ(nurimc_bus_send(&bus, &cmd, NULL), NURIMC_OK);
    deadline = now_ms() + 15000;
    while (!moved && now_ms() < deadline) {
        if (nurimc_bus_query(&bus, NURIMC_MSG_REQUEST_POSITION, 1, &a) == NURIMC_OK) {
            moved = a.u.position_feedback.position != start_position;
        }
    }
    CHECK(moved);

    /* a setting round trip: position gains, then the response time */
    cmd = nurimc_message_init(NURIMC_MSG_SET_POSITION_GAINS, 0);
    cmd.u.set_position_gains.kp = 77;
    cmd.u.set_position_gains.ki = 3;
    cmd.u.set_position_gains.kd = 21;
    cmd.u.set_position_gains.rated_current = 40;
    CHECK_EQ(nurimc_bus_send(&bus, &cmd, NULL), NURIMC_OK);
    CHECK_EQ(query(&bus, NURIMC_MSG_REQUEST_POSITION_GAINS, 0, &a), NURIMC_OK);
    CHECK_EQ(a.u.position_gains.kp, 77);
    CHECK_EQ(a.u.position_gains.ki, 3);
    CHECK_EQ(a.u.position_gains.kd, 21);
    CHECK_EQ(a.u.position_gains.rated_current, 40);
    cmd = nurimc_message_init(NURIMC_MSG_SET_RESPONSE_TIME, 0);
    cmd.u.set_response_time.response_time = 5;
    CHECK_EQ(nurimc_bus_send(&bus, &cmd, NULL), NURIMC_OK);
    CHECK_EQ(query(&bus, NURIMC_MSG_REQUEST_RESPONSE_TIME, 0, &a), NURIMC_OK);
    CHECK_EQ(a.u.response_time.response_time, 5);
    /* ID 1 kept its own settings */
    CHECK_EQ(query(&bus, NURIMC_MSG_REQUEST_RESPONSE_TIME, 1, &a), NURIMC_OK);
    CHECK_EQ(a.u.response_time.response_time, NURIMC_DEFAULT_RESPONSE_TIME);
    printf("ignored frames (echoes): %lu\n", (unsigned long)bus.ignored_frames);
    nurimc_bus_close(&bus);
    return check_report("test_sim");
}
