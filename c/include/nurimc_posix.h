/*
 * nurimc POSIX host layer: a serial port at any of the protocol's 18 rates (termios2 on
 * Linux, IOSSIOSPEED on macOS) and request/answer with deadlines computed from the wire,
 * keeping the EEPROM busy-window rule (docs/protocol.md, Busy window).
 */
#ifndef NURIMC_POSIX_H
#define NURIMC_POSIX_H

#include "nurimc.h"
#include "nurimc_host.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Defaults of the answer deadline (see nurimc_bus_answer_timeout_us), from spec/host.json. */
/* Each way; USB adapters hold bytes up to their latency timer (FTDI: 16 ms unless set to 1 ms:
 * set adapter_latency_us to NURIMC_HOST_USB_ADAPTER_LATENCY_US for an untuned one). */
#define NURIMC_DEFAULT_ADAPTER_LATENCY_US NURIMC_HOST_ADAPTER_LATENCY_US
#define NURIMC_DEFAULT_MARGIN_US          NURIMC_HOST_MARGIN_US /* scheduling slack of a busy host */
/* Assumed until you know the controllers' setting: the largest possible, 254 x 100 us. */
#define NURIMC_MAX_RESPONSE_TIME_US NURIMC_HOST_MAX_RESPONSE_TIME_US
/** busy_window_us / busy_windows_us value: not set (fall back to the next rule). */
#define NURIMC_BUSY_WINDOW_UNSET UINT32_MAX

/** An open serial port. */
typedef struct nurimc_port {
    int fd;        /**< -1 when closed */
    uint32_t baud; /**< the rate the port is set to */
} nurimc_port;

/** Open `path` raw 8N1 at `baud` (one of nurimc_baud_rates, else NURIMC_E_BAUD), locked for
 * this program: NURIMC_E_BUSY (errno EBUSY) if another program holds it (flock, as the Python
 * library takes it, or TIOCEXCL); while open, other programs' opens of it fail. */
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
    /* EEPROM busy windows: the window of ID i is busy_windows_us[i] if set, else busy_window_us
     * if set, else the busy window of products[i]'s profile (NURIMC_PROFILE_MC if not declared). */
    uint32_t busy_window_us;                       /**< for every ID; default NURIMC_BUSY_WINDOW_UNSET */
    uint32_t busy_windows_us[NURIMC_BROADCAST_ID]; /**< per ID 0-254; default NURIMC_BUSY_WINDOW_UNSET */
    int8_t products[NURIMC_BROADCAST_ID];          /**< nurimc_profile per ID, -1 = not declared (default) */
    uint64_t busy_until_us[NURIMC_BROADCAST_ID];   /**< monotonic time each ID is free again (0: free) */
    uint64_t busy_all_until_us;                    /**< after a broadcast write: every ID */
    uint32_t busy_waits;                           /**< frames held back until a busy window ended */
    int timeout_was_busy; /**< set with NURIMC_E_TIMEOUT when the ID was busy writing EEPROM (rule 6) */
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

/** The EEPROM busy window of `id` in microseconds (rule 2); NURIMC_BROADCAST_ID: the largest. */
uint32_t nurimc_bus_busy_window_us(const nurimc_bus *bus, uint8_t id);
/** Monotonic time (CLOCK_MONOTONIC, us) `id` may be sent a frame again; 0: any time. 255: every ID. */
uint64_t nurimc_bus_busy_until_us(const nurimc_bus *bus, uint8_t id);
/** Declare the product of controller `id` (0-254), for its default busy window. */
nurimc_status nurimc_bus_set_product(nurimc_bus *bus, uint8_t id, nurimc_profile product);

/**
 * Send one frame (a command, or a request whose answer you read yourself). It waits until
 * the ID's EEPROM busy window has ended (every ID's, for a broadcast); a command that starts
 * an EEPROM write (nurimc_writes_eeprom) makes its ID busy — set_id: the new ID too;
 * factory_reset: ID 0 too; a broadcast: every ID, for the largest window.
 */
nurimc_status nurimc_bus_send(nurimc_bus *bus, const nurimc_message *msg, int *bad_field);

/**
 * Send a feedback request (after the ID's busy window, as nurimc_bus_send) and wait for its
 * answer from the same ID until the deadline; retried `retries` times (reading twice is
 * harmless). Bytes already waiting are discarded before each attempt; frames that are not
 * the answer are counted in ignored_frames. NURIMC_E_TIMEOUT if no attempt got an answer,
 * with timeout_was_busy set if the request went out less than one more busy window after the
 * ID's window ended: the controller is busy writing its settings (EEPROM) — give it a longer
 * busy window — rather than missing or miswired. NURIMC_E_ARGUMENT if `request` is not a
 * request type. Commands are never retried (use nurimc_bus_send).
 */
nurimc_status nurimc_bus_request(nurimc_bus *bus, const nurimc_message *request, nurimc_message *answer);

/** Ask controller `id` for answer type of `request_type` (no fields), e.g. NURIMC_MSG_REQUEST_PING. */
nurimc_status nurimc_bus_query(nurimc_bus *bus, nurimc_message_type request_type, uint8_t id, nurimc_message *answer);

#ifdef __cplusplus
}
#endif

#endif
