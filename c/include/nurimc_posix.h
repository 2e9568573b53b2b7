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
/* Each way; USB adapters hold bytes up to their latency timer (FTDI: 16 ms unless set to 1 ms). */
#define NURIMC_DEFAULT_ADAPTER_LATENCY_US 10000u
#define NURIMC_DEFAULT_MARGIN_US 3000u /* scheduling slack of a busy host */
/* Assumed until you know the controllers' setting: the largest possible, 254 x 100 us. */
#define NURIMC_MAX_RESPONSE_TIME_US 25400u

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
    uint32_t adapter_latency_us; /**< each way; default NURIMC_DEFAULT_ADAPTER_LATENCY_US */
    uint32_t margin_us;          /**< default NURIMC_DEFAULT_MARGIN_US */
    uint32_t response_time_us;   /**< the controllers' response time setting x 100 us; default the maximum */
    uint8_t retries;             /**< extra attempts of a request that got no answer; default 2 */
    uint32_t retry_pause_us;     /**< pause before a retry; default 5 ms */
    nurimc_parser parser;
    uint32_t ignored_frames; /**< frames read that were not the awaited answer (echoes, other traffic) */
} nurimc_bus;

/** Open the bus on `path` at `baud` with the default timing. */
nurimc_status nurimc_bus_open(nurimc_bus *bus, const char *path, uint32_t baud);
void nurimc_bus_close(nurimc_bus *bus);

/**
 * The answer deadline for `request`, in microseconds from the end of the write, as the Python
 * library computes it: wire time of the request and of its answer (bytes x 10 / baud)
 * + the controller's response time + 2 x adapter latency (both ways) + margin.
 */
uint32_t nurimc_bus_answer_timeout_us(const nurimc_bus *bus, nurimc_message_type request);

/** Send one frame (a command, or a request whose answer you read yourself). */
nurimc_status nurimc_bus_send(nurimc_bus *bus, const nurimc_message *msg, int *bad_field);

/**
 * Send a feedback request and wait for its answer from the same ID until the deadline;
 * retried `retries` times (reading twice is harmless; a controller writing its EEPROM after a
 * settings command ignores requests for 50-300 ms). Bytes already waiting are discarded
 * before each attempt; frames that are not the answer are counted in ignored_frames.
 * NURIMC_E_TIMEOUT if no attempt got an answer; NURIMC_E_ARGUMENT if `request` is not a
 * request type. Commands are never retried (use nurimc_bus_send).
 */
nurimc_status nurimc_bus_request(nurimc_bus *bus, const nurimc_message *request, nurimc_message *answer);

/** Ask controller `id` for answer type of `request_type` (no fields), e.g. NURIMC_MSG_REQUEST_PING. */
nurimc_status nurimc_bus_query(nurimc_bus *bus, nurimc_message_type request_type, uint8_t id,
                               nurimc_message *answer);

#ifdef __cplusplus
}
#endif

#endif
