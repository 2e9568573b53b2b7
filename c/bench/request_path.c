/*
 * The request path of the POSIX host layer against a bare read()/write() loop (issue 33):
 * position feedback from one controller, request (6 bytes) + answer (12 bytes), for SECONDS.
 * Usage: nurimc_request_path KIND LINK SECONDS   (KIND: library or bare)
 * Prints one JSON object: {"cycles", "failed", "wall", "cpu"} (cpu: this process's user + system
 * time, CLOCK_PROCESS_CPUTIME_ID). benchmarks/request_path_bench.py runs it, alternating the kinds.
 *
 * library: nurimc_bus_query(REQUEST_POSITION) and the answer in degrees, as a program reads a
 *          motor's state (the bus's defaults: deadline from the wire, retries, busy windows).
 * bare:    the least a program can do: a blocking fd in raw mode, write() the 6 request bytes,
 *          read() until the 12 answer bytes are in (VTIME: 0.1 s without a byte is a failure).
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "nurimc.h"
#include "nurimc_posix.h"
#include "nurimc_units.h"

#define ID          1u
#define BAUD        1000000u
#define WARM_UP     50
#define ANSWER_SIZE 12

static double clock_s(clockid_t clock) {
    struct timespec ts;
    clock_gettime(clock, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static volatile double sink;

typedef struct bare_link {
    int fd;
    uint8_t request[NURIMC_MAX_FRAME_LENGTH];
    size_t length;
} bare_link;

static int bare_open(bare_link *link, const char *path) {
    struct termios tio;
    nurimc_message request = nurimc_message_init(NURIMC_MSG_REQUEST_POSITION, (uint8_t)ID);
    link->fd = open(path, O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (link->fd < 0 || tcgetattr(link->fd, &tio) != 0) return -1;
    tio.c_iflag &= (tcflag_t) ~(IGNBRK | BRKINT | PARMRK | ISTRIP | INLCR | IGNCR | ICRNL | IXON);
    tio.c_oflag &= (tcflag_t)~OPOST;
    tio.c_lflag &= (tcflag_t) ~(ECHO | ECHONL | ICANON | ISIG | IEXTEN);
    tio.c_cflag &= (tcflag_t) ~(CSIZE | PARENB | CSTOPB);
    tio.c_cflag |= CS8 | CLOCAL | CREAD;
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 1; /* a read with nothing for 0.1 s returns 0: no answer */
    if (tcsetattr(link->fd, TCSANOW, &tio) != 0) return -1;
    return nurimc_encode(&request, link->request, sizeof link->request, &link->length, NULL) == NURIMC_OK ? 0 : -1;
}

/* One request and its answer; 1 if the 12 bytes came. */
static int bare_once(const bare_link *link) {
    uint8_t answer[ANSWER_SIZE];
    size_t got = 0;
    if (write(link->fd, link->request, link->length) != (ssize_t)link->length) return 0;
    while (got < sizeof answer) {
        ssize_t n = read(link->fd, answer + got, sizeof answer - got);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return 0;
        got += (size_t)n;
    }
    return 1;
}

/* One read of the motor's state through the library; 1 on an answer. */
static int library_once(nurimc_bus *bus) {
    nurimc_message answer;
    if (nurimc_bus_query(bus, NURIMC_MSG_REQUEST_POSITION, (uint8_t)ID, &answer) != NURIMC_OK) return 0;
    sink = nurimc_degrees_from_wire(answer.u.position_feedback.position, answer.u.position_feedback.direction);
    return 1;
}

int main(int argc, char **argv) {
    nurimc_bus bus;
    bare_link link;
    int library, i;
    unsigned long cycles = 0, failed = 0;
    double seconds, start, cpu0, end, wall, cpu;
    if (argc != 4 || (strcmp(argv[1], "library") != 0 && strcmp(argv[1], "bare") != 0)) {
        fprintf(stderr, "usage: %s library|bare LINK SECONDS\n", argv[0]);
        return 2;
    }
    library = strcmp(argv[1], "library") == 0;
    seconds = atof(argv[3]);
    if (!(seconds > 0)) {
        fprintf(stderr, "SECONDS must be a positive number, not %s\n", argv[3]);
        return 2;
    }
    if (library ? nurimc_bus_open(&bus, argv[2], BAUD) != NURIMC_OK : bare_open(&link, argv[2]) != 0) {
        fprintf(stderr, "cannot open %s: %s\n", argv[2], strerror(errno));
        return 1;
    }
    for (i = 0; i < WARM_UP; i++) (void)(library ? library_once(&bus) : bare_once(&link));
    cpu0 = clock_s(CLOCK_PROCESS_CPUTIME_ID);
    start = clock_s(CLOCK_MONOTONIC);
    end = start + seconds;
    do {
        int ok = library ? library_once(&bus) : bare_once(&link);
        cycles++;
        failed += !ok;
    } while (clock_s(CLOCK_MONOTONIC) < end);
    wall = clock_s(CLOCK_MONOTONIC) - start;
    cpu = clock_s(CLOCK_PROCESS_CPUTIME_ID) - cpu0;
    printf("{\"cycles\": %lu, \"failed\": %lu, \"wall\": %.6f, \"cpu\": %.6f}\n", cycles, failed, wall, cpu);
    if (library)
        nurimc_bus_close(&bus);
    else
        close(link.fd);
    return 0;
}
