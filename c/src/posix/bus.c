/* Request/answer over a serial port, with deadlines computed from the wire timing and the
 * EEPROM busy-window rule (docs/protocol.md, Busy window). */
#define _POSIX_C_SOURCE 200809L
#include "nurimc_posix.h"

#include <errno.h>
#include <poll.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

int nurimc_port_discard_input(const nurimc_port *port);

#define ID_COUNT ((int)NURIMC_BROADCAST_ID) /* IDs 0-254 */

static uint64_t now_us(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static void pause_us(uint32_t us) {
    struct timespec ts;
    ts.tv_sec = (time_t)(us / 1000000u);
    ts.tv_nsec = (long)(us % 1000000u) * 1000L;
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {}
}

nurimc_status nurimc_bus_open(nurimc_bus *bus, const char *path, uint32_t baud) {
    int i;
    if (bus == NULL) return NURIMC_E_ARGUMENT;
    memset(bus, 0, sizeof *bus);
    bus->adapter_latency_us = NURIMC_DEFAULT_ADAPTER_LATENCY_US;
    bus->margin_us = NURIMC_DEFAULT_MARGIN_US;
    bus->response_time_us = NURIMC_MAX_RESPONSE_TIME_US;
    bus->retries = NURIMC_HOST_RETRIES;
    bus->retry_pause_us = NURIMC_HOST_RETRY_PAUSE_US;
    bus->busy_window_us = NURIMC_BUSY_WINDOW_UNSET;
    for (i = 0; i < ID_COUNT; i++) {
        bus->busy_windows_us[i] = NURIMC_BUSY_WINDOW_UNSET;
        bus->products[i] = -1;
    }
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

static uint64_t wire_us(const nurimc_bus *bus, size_t bytes) {
    if (bus->port.baud == 0) return 0;
    return ((uint64_t)bytes * NURIMC_HOST_BITS_PER_BYTE * 1000000u + bus->port.baud - 1u) / bus->port.baud;
}

static uint32_t default_window_us(const nurimc_bus *bus) {
    if (bus->busy_window_us != NURIMC_BUSY_WINDOW_UNSET) return bus->busy_window_us;
    return nurimc_profile_busy_window_us(NURIMC_DEFAULT_PROFILE);
}

uint32_t nurimc_bus_busy_window_us(const nurimc_bus *bus, uint8_t id) {
    if (bus == NULL) return 0;
    if (id == NURIMC_BROADCAST_ID) { /* the largest of every window set or declared, and the default */
        uint32_t largest = default_window_us(bus);
        int i;
        for (i = 0; i < ID_COUNT; i++) {
            if (bus->busy_windows_us[i] != NURIMC_BUSY_WINDOW_UNSET || bus->products[i] >= 0) {
                uint32_t window = nurimc_bus_busy_window_us(bus, (uint8_t)i);
                if (window > largest) largest = window;
            }
        }
        return largest;
    }
    if (bus->busy_windows_us[id] != NURIMC_BUSY_WINDOW_UNSET) return bus->busy_windows_us[id];
    if (bus->busy_window_us != NURIMC_BUSY_WINDOW_UNSET) return bus->busy_window_us;
    return nurimc_profile_busy_window_us(bus->products[id] >= 0 ? (nurimc_profile)bus->products[id]
                                                                : NURIMC_DEFAULT_PROFILE);
}

uint64_t nurimc_bus_busy_until_us(const nurimc_bus *bus, uint8_t id) {
    uint64_t until;
    int i;
    if (bus == NULL) return 0;
    until = bus->busy_all_until_us;
    if (id != NURIMC_BROADCAST_ID) return bus->busy_until_us[id] > until ? bus->busy_until_us[id] : until;
    for (i = 0; i < ID_COUNT; i++) {
        if (bus->busy_until_us[i] > until) until = bus->busy_until_us[i];
    }
    return until;
}

nurimc_status nurimc_bus_set_product(nurimc_bus *bus, uint8_t id, nurimc_profile product) {
    if (bus == NULL || id >= NURIMC_BROADCAST_ID || (int)product < 0 || product >= NURIMC_PROFILE_COUNT) {
        return NURIMC_E_ARGUMENT;
    }
    bus->products[id] = (int8_t)product;
    return NURIMC_OK;
}

/* Rule 4: no frame to `id` (255: to any) before its busy window has ended. */
static void wait_until_free(nurimc_bus *bus, uint8_t id) {
    uint64_t until = nurimc_bus_busy_until_us(bus, id), now = now_us();
    if (until <= now) return;
    bus->busy_waits++;
    while (until > now) {
        uint64_t left = until - now;
        pause_us(left > 1000000u ? 1000000u : (uint32_t)left);
        now = now_us();
    }
}

static void mark_one(nurimc_bus *bus, uint8_t id, uint64_t end) {
    uint64_t until = end + nurimc_bus_busy_window_us(bus, id);
    if (id == NURIMC_BROADCAST_ID) {
        if (until > bus->busy_all_until_us) bus->busy_all_until_us = until;
    } else if (until > bus->busy_until_us[id]) {
        bus->busy_until_us[id] = until;
    }
}

/* Rule 3: after the write, an EEPROM-writing command makes its ID(s) busy. */
static void mark_busy(nurimc_bus *bus, const nurimc_message *msg, size_t frame_length) {
    uint64_t end;
    if (!nurimc_writes_eeprom(msg->type)) return;
    end = now_us() + wire_us(bus, frame_length) + bus->adapter_latency_us;
    mark_one(bus, msg->id, end);
    if (msg->type == NURIMC_MSG_SET_ID) mark_one(bus, msg->u.set_id.new_id, end);
    if (msg->type == NURIMC_MSG_FACTORY_RESET && msg->id != NURIMC_BROADCAST_ID)
        mark_one(bus, 0, end); /* back as ID 0 */
}

/* Rule 6: was a request sent at `sent_at` within one more window after the ID's window ended? */
static int recently_busy(const nurimc_bus *bus, uint8_t id, uint64_t sent_at) {
    uint64_t until = nurimc_bus_busy_until_us(bus, id);
    return until > 0 && sent_at < until + nurimc_bus_busy_window_us(bus, id);
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
    wait_until_free(bus, msg->id);
    status = write_all(bus->port.fd, frame, length);
    if (status == NURIMC_OK) mark_busy(bus, msg, length);
    return status;
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
    uint64_t first_sent_at;
    if (bus == NULL || answer == NULL || spec == NULL || spec->kind != NURIMC_KIND_REQUEST) {
        return NURIMC_E_ARGUMENT;
    }
    bus->timeout_was_busy = 0;
    if (request->id >= NURIMC_BROADCAST_ID) return NURIMC_E_RANGE; /* requests are never broadcast */
    wait_until_free(bus, request->id);
    first_sent_at = now_us();
    for (tries = 0;; tries++) {
        status = attempt(bus, request, spec, answer);
        if (status != NURIMC_E_TIMEOUT || tries >= bus->retries) break;
        pause_us(bus->retry_pause_us);
    }
    if (status == NURIMC_E_TIMEOUT) bus->timeout_was_busy = recently_busy(bus, request->id, first_sent_at);
    return status;
}

nurimc_status nurimc_bus_query(nurimc_bus *bus, nurimc_message_type request_type, uint8_t id, nurimc_message *answer) {
    nurimc_message request = nurimc_message_init(request_type, id);
    return nurimc_bus_request(bus, &request, answer);
}
