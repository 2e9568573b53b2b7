/* Request/answer over a serial port, with deadlines computed from the wire timing. */
#define _POSIX_C_SOURCE 200809L
#include "nurimc_posix.h"

#include <errno.h>
#include <poll.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

int nurimc_port_discard_input(const nurimc_port *port);

static uint64_t now_us(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static void pause_us(uint32_t us) {
    struct timespec ts;
    ts.tv_sec = (time_t)(us / 1000000u);
    ts.tv_nsec = (long)(us % 1000000u) * 1000L;
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
    }
}

nurimc_status nurimc_bus_open(nurimc_bus *bus, const char *path, uint32_t baud) {
    if (bus == NULL) return NURIMC_E_ARGUMENT;
    memset(bus, 0, sizeof *bus);
    bus->adapter_latency_us = NURIMC_DEFAULT_ADAPTER_LATENCY_US;
    bus->margin_us = NURIMC_DEFAULT_MARGIN_US;
    bus->response_time_us = NURIMC_MAX_RESPONSE_TIME_US;
    bus->retries = 2;
    bus->retry_pause_us = 5000;
    nurimc_parser_init(&bus->parser);
    return nurimc_port_open(&bus->port, path, baud);
}

void nurimc_bus_close(nurimc_bus *bus) {
    if (bus != NULL) nurimc_port_close(&bus->port);
}

uint32_t nurimc_bus_answer_timeout_us(const nurimc_bus *bus, nurimc_message_type request) {
    const nurimc_message_spec *spec = nurimc_spec(request);
    const nurimc_message_spec *answer = spec ? nurimc_spec(spec->answer) : NULL;
    uint64_t bytes, wire_us, total;
    if (bus == NULL || spec == NULL || bus->port.baud == 0) return 0;
    bytes = (uint64_t)spec->size + NURIMC_FRAME_OVERHEAD;
    if (answer != NULL) bytes += (uint64_t)answer->size + NURIMC_FRAME_OVERHEAD;
    wire_us = (bytes * 10u * 1000000u + bus->port.baud - 1u) / bus->port.baud; /* 8N1: 10 bits a byte */
    total = wire_us + bus->response_time_us + 2u * (uint64_t)bus->adapter_latency_us + bus->margin_us;
    return total > UINT32_MAX ? UINT32_MAX : (uint32_t)total;
}

static nurimc_status write_all(int fd, const uint8_t *data, size_t length) {
    while (length > 0) {
        ssize_t n = write(fd, data, length);
        if (n < 0) {
            struct pollfd pfd;
            if (errno == EINTR) continue;
            if (errno != EAGAIN && errno != EWOULDBLOCK) return NURIMC_E_IO;
            pfd.fd = fd;
            pfd.events = POLLOUT;
            if (poll(&pfd, 1, 1000) <= 0) return NURIMC_E_IO; /* output stuck for a second */
            continue;
        }
        data += n;
        length -= (size_t)n;
    }
    return NURIMC_OK;
}

nurimc_status nurimc_bus_send(nurimc_bus *bus, const nurimc_message *msg, int *bad_field) {
    uint8_t frame[NURIMC_MAX_FRAME_LENGTH];
    size_t length = 0;
    nurimc_status status;
    if (bus == NULL || bus->port.fd < 0) return NURIMC_E_ARGUMENT;
    status = nurimc_encode(msg, frame, sizeof frame, &length, bad_field);
    if (status != NURIMC_OK) return status;
    return write_all(bus->port.fd, frame, length);
}

static nurimc_status attempt(nurimc_bus *bus, const nurimc_message *request, const nurimc_message_spec *spec,
                             nurimc_message *answer) {
    uint64_t deadline;
    nurimc_status status;
    nurimc_port_discard_input(&bus->port);
    nurimc_parser_clear(&bus->parser);
    status = nurimc_bus_send(bus, request, NULL);
    if (status != NURIMC_OK) return status;
    deadline = now_us() + nurimc_bus_answer_timeout_us(bus, request->type);
    for (;;) {
        uint8_t chunk[64];
        struct pollfd pfd;
        uint64_t now = now_us();
        ssize_t n, i;
        int ready;
        if (now >= deadline) return NURIMC_E_TIMEOUT;
        pfd.fd = bus->port.fd;
        pfd.events = POLLIN;
        ready = poll(&pfd, 1, (int)((deadline - now + 999u) / 1000u));
        if (ready < 0 && errno != EINTR) return NURIMC_E_IO;
        if (ready <= 0) continue;
        n = read(bus->port.fd, chunk, sizeof chunk);
        if (n < 0) {
            if (errno == EINTR || errno == EAGAIN || errno == EWOULDBLOCK) continue;
            return NURIMC_E_IO;
        }
        if (n == 0) { /* hang-up (the other end of a pty closed): nothing more will come */
            return NURIMC_E_IO;
        }
        for (i = 0; i < n; i++) {
            if (!nurimc_parser_push(&bus->parser, chunk[i], answer)) continue;
            if (answer->type == spec->answer && answer->id == request->id) return NURIMC_OK;
            bus->ignored_frames++; /* an echo of our request, or another controller's traffic */
        }
    }
}

nurimc_status nurimc_bus_request(nurimc_bus *bus, const nurimc_message *request, nurimc_message *answer) {
    const nurimc_message_spec *spec = request ? nurimc_spec(request->type) : NULL;
    nurimc_status status;
    unsigned tries;
    if (bus == NULL || answer == NULL || spec == NULL || spec->kind != NURIMC_KIND_REQUEST) {
        return NURIMC_E_ARGUMENT;
    }
    for (tries = 0;; tries++) {
        status = attempt(bus, request, spec, answer);
        if (status != NURIMC_E_TIMEOUT || tries >= bus->retries) return status;
        pause_us(bus->retry_pause_us);
    }
}

nurimc_status nurimc_bus_query(nurimc_bus *bus, nurimc_message_type request_type, uint8_t id,
                               nurimc_message *answer) {
    nurimc_message request = nurimc_message_init(request_type, id);
    return nurimc_bus_request(bus, &request, answer);
}
