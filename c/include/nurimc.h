/*
 * nurimc — MC-RS485 V1.0.1 protocol core for C99 and C++.
 *
 * Sans-I/O: no dynamic allocation, no global state, no I/O and no dependence on host
 * endianness. Field values are raw wire integers (see docs/protocol.md for units;
 * <nurimc_units.h> converts physical values).
 * The message table is generated from spec/protocol.json (nurimc_messages.h).
 * The POSIX serial host layer is in <nurimc_posix.h>.
 */
#ifndef NURIMC_H
#define NURIMC_H

#include <stddef.h>
#include <stdint.h>

#include "nurimc_messages.h"

/*
 * Where the generated tables live. An AVR (Arduino Uno, Mega) copies every const object into
 * its RAM at start-up unless it is marked for program memory: the tables are 1.7 kB, most of an
 * Uno's 2 kB. With NURIMC_TABLES_IN_FLASH (the Arduino package sets it on AVR, and marks its
 * copy of the tables with NURIMC_FLASH) the library reads them with LPM instead; elsewhere these
 * macros are plain reads and cost nothing. In that mode nurimc_spec() returns a copy in RAM
 * whose `fields` still point into program memory (use nurimc_get_field/nurimc_set_field).
 */
#if defined(__AVR__) && defined(NURIMC_TABLES_IN_FLASH)
#include <avr/pgmspace.h>
#define NURIMC_FLASH             PROGMEM
#define NURIMC_TABLE_U8(lvalue)  pgm_read_byte(&(lvalue))
#define NURIMC_TABLE_U16(lvalue) pgm_read_word(&(lvalue))
#define NURIMC_TABLE_PTR(lvalue) pgm_read_ptr(&(lvalue))
#else
#define NURIMC_FLASH
#define NURIMC_TABLE_U8(lvalue)  (lvalue)
#define NURIMC_TABLE_U16(lvalue) (lvalue)
#define NURIMC_TABLE_PTR(lvalue) (lvalue)
#endif

#ifdef __cplusplus
extern "C" {
#endif

#define NURIMC_VERSION "0.1.0"

/** Result of every fallible call. The decode kinds come first, in the order decode checks them. */
typedef enum nurimc_status {
    NURIMC_OK = 0,
    NURIMC_E_HEADER,          /**< decode: the frame does not start with FF FE */
    NURIMC_E_TRUNCATED,       /**< decode: fewer than 6 bytes, or fewer than size + 4 */
    NURIMC_E_TRAILING,        /**< decode: more than size + 4 bytes */
    NURIMC_E_CHECKSUM,        /**< decode: checksum byte differs from the bytes */
    NURIMC_E_UNKNOWN_MODE,    /**< decode: no message has this mode */
    NURIMC_E_SIZE,            /**< decode: the size byte does not fit the mode's layout */
    NURIMC_E_UNKNOWN_MESSAGE, /**< encode: no such message type / name */
    NURIMC_E_RANGE,           /**< encode: the ID or a field is out of its range */
    NURIMC_E_BUFFER,          /**< the output buffer is too small (NURIMC_MAX_FRAME_LENGTH always fits) */
    NURIMC_E_ARGUMENT,        /**< a NULL pointer or other invalid argument */
    NURIMC_E_IO,              /**< host layer: the operating system reported an error (see errno) */
    NURIMC_E_TIMEOUT,         /**< host layer: no answer before the deadline */
    NURIMC_E_BAUD,            /**< host layer: not one of the 18 protocol baud rates */
    NURIMC_E_NOT_FINITE,      /**< units: the value is NaN or infinite */
    NURIMC_E_FRACTION,        /**< units: a fraction where a whole number is needed */
    NURIMC_E_BUSY             /**< host layer: another program holds the port (flock / TIOCEXCL) */
} nurimc_status;

/** Message kinds: commands are never answered; requests are answered with mode + 0x30. */
typedef enum nurimc_kind { NURIMC_KIND_COMMAND, NURIMC_KIND_REQUEST, NURIMC_KIND_ANSWER } nurimc_kind;

#define NURIMC_MSG_NONE ((nurimc_message_type) - 1)
/** `bad_field` value when the ID (not a field) was out of range. */
#define NURIMC_FIELD_ID (-1)
/** `bad_field` value when no field is to blame. */
#define NURIMC_FIELD_NONE (-2)

/** One field of a message: its wire range and unit. physical = raw * scale_num / scale_den. */
typedef struct nurimc_field_spec {
    const char *name;
    const char *unit; /**< "" when the field has no unit */
    uint16_t min, max;
    uint16_t scale_num, scale_den;
    uint8_t width;   /**< bytes on the wire (1 or 2, big-endian) */
    uint16_t offset; /**< offset of the value inside nurimc_message */
} nurimc_field_spec;

/** One message type as the spec defines it. */
typedef struct nurimc_message_spec {
    const char *name; /**< canonical name, e.g. "position_speed" */
    const char *title;
    nurimc_kind kind;
    uint8_t mode;
    uint8_t size;   /**< the frame's size byte; frame length = size + 4 */
    uint8_t max_id; /**< 255 for commands (broadcast), 254 otherwise */
    uint8_t field_count;
    const nurimc_field_spec *fields; /**< in wire order; NULL when there are none */
    nurimc_message_type answer;      /**< for requests, the answer type; else NURIMC_MSG_NONE */
    nurimc_message_type request;     /**< for answers, the request type; else NURIMC_MSG_NONE */
} nurimc_message_spec;

/* Generated tables (read-only). */
extern const nurimc_message_spec nurimc_message_specs[NURIMC_MESSAGE_COUNT];
extern const uint8_t nurimc_type_by_mode_plus_one[256];
extern const uint32_t nurimc_baud_rates[NURIMC_BAUD_RATE_COUNT];

/* ---- tables ---------------------------------------------------------------------------- */

/** The spec of a message type, or NULL if `type` is not one. */
const nurimc_message_spec *nurimc_spec(nurimc_message_type type);
/** The type with this canonical name, or NURIMC_MSG_NONE. */
nurimc_message_type nurimc_type_by_name(const char *name);
/** The type with this mode byte, or NURIMC_MSG_NONE. */
nurimc_message_type nurimc_type_by_mode(uint8_t mode);
/** Index of the field with this name in `type`, or -1. */
int nurimc_field_index(nurimc_message_type type, const char *name);
/** A short English text for a status, e.g. "bad checksum". Never NULL. */
const char *nurimc_status_text(nurimc_status status);
/** The conformance name of a status, e.g. "checksum", "range". Never NULL. */
const char *nurimc_status_name(nurimc_status status);
/** The index of `baud` in the protocol's baud-rate table, or -1. */
int nurimc_baud_index(uint32_t baud);

/* ---- messages -------------------------------------------------------------------------- */

/** A message of `type` for controller `id` with every field zero. */
nurimc_message nurimc_message_init(nurimc_message_type type, uint8_t id);
/** Field `index` (wire order) of `msg` as an integer; 0 if there is no such field. */
uint16_t nurimc_get_field(const nurimc_message *msg, int index);
/** Set field `index` of `msg`; NURIMC_E_RANGE if it does not fit the field's width. */
nurimc_status nurimc_set_field(nurimc_message *msg, int index, uint16_t value);

/* ---- codec ----------------------------------------------------------------------------- */

/** ~(id + size + mode + data...) & 0xFF over a whole frame (bytes 2..end, skipping byte 4). */
uint8_t nurimc_checksum(const uint8_t *frame, size_t length);

/**
 * Encode `msg` into `out` (capacity bytes; NURIMC_MAX_FRAME_LENGTH always fits).
 * Checks the ID (0-255 for commands, 0-254 otherwise) and every field's range first;
 * on NURIMC_E_RANGE, *bad_field (if not NULL) is NURIMC_FIELD_ID or the field's index.
 * *length (if not NULL) receives the frame length.
 */
nurimc_status nurimc_encode(const nurimc_message *msg, uint8_t *out, size_t capacity, size_t *length, int *bad_field);

/**
 * Encode from wide integers in wire order (as a dynamic-language binding or a JSON layer
 * would hold them), so values like -1 or 65536 get a proper NURIMC_E_RANGE.
 */
nurimc_status nurimc_encode_values(nurimc_message_type type, long id, const long *values, uint8_t *out, size_t capacity,
                                   size_t *length, int *bad_field);

/**
 * Decode exactly one whole frame. Errors in this order: header, truncated, trailing,
 * checksum, unknown mode, size. Out-of-range field values decode as they are.
 */
nurimc_status nurimc_decode(const uint8_t *frame, size_t length, nurimc_message *out);

/* ---- stream parser --------------------------------------------------------------------- */

/** What a parser has seen since nurimc_parser_init. */
typedef struct nurimc_parser_stats {
    uint32_t frames;        /**< frames returned */
    uint32_t dropped_bytes; /**< every byte not part of a returned frame */
    uint32_t bad_checksum;  /**< candidates rejected for their checksum */
    uint32_t unknown_mode;  /**< candidates rejected for their mode */
    uint32_t bad_size;      /**< candidates rejected for their size byte */
} nurimc_parser_stats;

/**
 * Bytes in any chunking -> whole frames. Rule: where a whole valid frame starts, take it;
 * otherwise drop one byte and look again from the next. Holds at most one frame's bytes.
 * Zero-initialise or call nurimc_parser_init; no other set-up; one per byte stream.
 */
typedef struct nurimc_parser {
    uint8_t buf[NURIMC_MAX_FRAME_LENGTH];
    uint8_t length;
    uint8_t next;  /**< internal: bytes at indexes below this extend the held candidate unchecked */
    uint8_t state; /**< internal: 0 = buf holds one undecided candidate (or nothing); 1 = re-scan it */
    nurimc_parser_stats stats;
} nurimc_parser;

void nurimc_parser_init(nurimc_parser *parser);
/**
 * Add one byte; returns 1 and fills *out when that byte completes a frame, else 0 (also when
 * parser or out is NULL: the byte is then ignored). The same as nurimc_parser_push, out of line:
 * one exported symbol, e.g. for a function pointer or a foreign-function binding.
 */
int nurimc_parser_push_checked(nurimc_parser *parser, uint8_t byte, nurimc_message *out);
/** Internal, for nurimc_parser_push only: a byte that needs a look (parser and out not NULL). */
int nurimc_parser_push_boundary_(nurimc_parser *parser, uint8_t byte, nurimc_message *out);
/**
 * Add one byte; returns 1 and fills *out when that byte completes a frame, else 0 (also when
 * parser or out is NULL: the byte is then ignored). Inline: a byte inside a candidate frame
 * that needs no check yet (its ID, size, checksum and data bytes but the last) is only stored
 * here; every other byte (FF, FE, the mode byte, the last byte, noise) is judged out of line
 * (docs/performance.md). The NULL checks cost nothing when the compiler sees the pointers are
 * addresses of objects (&parser, &msg).
 */
static inline int nurimc_parser_push(nurimc_parser *parser, uint8_t byte, nurimc_message *out) {
    unsigned n;
    if (parser == NULL || out == NULL) return 0;
    n = parser->length;
    if (n < parser->next) { /* the ID, size, checksum or a data byte but the last: no check yet */
        parser->buf[n] = byte;
        parser->length = (uint8_t)(n + 1u);
        return 0;
    }
    return nurimc_parser_push_boundary_(parser, byte, out);
}
/** Called by nurimc_parser_feed for every frame, in order. */
typedef void (*nurimc_frame_callback)(void *context, const nurimc_message *msg);
/** Add `length` bytes; calls `callback` for each frame they complete. Returns the frame count. */
size_t nurimc_parser_feed(nurimc_parser *parser, const uint8_t *data, size_t length, nurimc_frame_callback callback,
                          void *context);
/**
 * End of stream (or the line went quiet): resolve held bytes; a partial frame is dropped
 * byte by byte so a real frame inside it is still found. Returns 1 and fills *out for each
 * such frame; call until it returns 0.
 */
int nurimc_parser_finish(nurimc_parser *parser, nurimc_message *out);
/** Forget held bytes (counted as dropped), e.g. before sending a new request. */
void nurimc_parser_clear(nurimc_parser *parser);
/** Bytes held because they may begin a frame (a candidate's FE and size byte are judged
    with its mode byte: up to five held bytes may turn out not to). */
size_t nurimc_parser_pending(const nurimc_parser *parser);

#ifdef __cplusplus
}
#endif

#endif
