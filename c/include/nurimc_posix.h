/*
 * nurimc POSIX host layer: a serial port at any of the protocol's 18 rates (termios2 on
 * Linux, IOSSIOSPEED on macOS) and request/answer with deadlines computed from the wire.
 */
#ifndef NURIMC_POSIX_H
#define NURIMC_POSIX_H

#include "nurimc.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Defaults of the answer deadline (see nurimc_bus_answer_timeout_us). */
#define NURIMC_DEFAULT_ADAPTER_LATENCY_US 20000u /* USB-RS485 adapters buffer up to ~16 ms */
#define NURIMC_DEFAULT_MARGIN_US 10000u

/** An open serial port. */
typedef struct nurimc_port {
    int fd;        /**< -1 when closed */
    uint32_t baud; /**< the rate the port is set to */
} nurimc_port;

/** Open `path` raw 8N1 at `baud` (one of nurimc_baud_rates, else NURIMC_E_BAUD). */
nurimc_status nurimc_port_open(nurimc_port *port, const char *path, uint32_t baud);
/** Change the rate of an open port. */
nurimc_status nurimc_port_set_baud(nurimc_port *port, uint32_t baud);
/** Close the port (safe to call twice). */
void nurimc_port_close(nurimc_port *port);

/** One RS485 bus seen from the host: the port, a stream parser and the timing settings. */
typedef struct nurimc_bus {
    nurimc_port port;
    uint32_t adapter_latency_us; /**< added to every deadline; default NURIMC_DEFAULT_ADAPTER_LATENCY_US */
    uint32_t margin_us;          /**< added to every deadline; default NURIMC_DEFAULT_MARGIN_US */
    uint32_t response_time_us;   /**< the controllers' response time (field x 100 us); default 100 us */
    nurimc_parser parser;
    uint32_t ignored_frames; /**< frames read that were not the awaited answer (echoes, other traffic) */
} nurimc_bus;

/** Open the bus on `path` at `baud` with the default timing. */
nurimc_status nurimc_bus_open(nurimc_bus *bus, const char *path, uint32_t baud);
void nurimc_bus_close(nurimc_bus *bus);

/**
 * The answer deadline for `request`, in microseconds: wire time of the request and of its
 * answer (bytes x 10 / baud) + the controller's response time + adapter latency + margin.
 */
uint32_t nurimc_bus_answer_timeout_us(const nurimc_bus *bus, nurimc_message_type request);

/** Send one frame (a command, or a request whose answer you read yourself). */
nurimc_status nurimc_bus_send(nurimc_bus *bus, const nurimc_message *msg, int *bad_field);

/**
 * Send a feedback request and wait for its answer from the same ID until the deadline.
 * Bytes already waiting are discarded first; frames that are not the answer are counted in
 * ignored_frames. NURIMC_E_TIMEOUT if no answer came; NURIMC_E_ARGUMENT if `request` is
 * not a request type.
 */
nurimc_status nurimc_bus_request(nurimc_bus *bus, const nurimc_message *request, nurimc_message *answer);

/** Ask controller `id` for answer type of `request_type` (no fields), e.g. NURIMC_MSG_REQUEST_PING. */
nurimc_status nurimc_bus_query(nurimc_bus *bus, nurimc_message_type request_type, uint8_t id,
                               nurimc_message *answer);

#ifdef __cplusplus
}
#endif

#endif
