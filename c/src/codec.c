/* Tables lookup, field access, encode and decode of whole frames. */
#include "nurimc.h"

#include <string.h>

/* Byte offsets inside a frame. */
enum { ID_OFFSET = 2, SIZE_OFFSET = 3, CHECKSUM_OFFSET = 4, MODE_OFFSET = 5, DATA_OFFSET = 6 };

/* The spec of a valid type: the table's own row, or (tables in AVR flash) a copy in `copy`. */
static const nurimc_message_spec *spec_of(nurimc_message_type type, nurimc_message_spec *copy) {
#if defined(__AVR__) && defined(NURIMC_TABLES_IN_FLASH)
    memcpy_P(copy, &nurimc_message_specs[type], sizeof *copy);
    return copy;
#else
    (void)copy;
    return &nurimc_message_specs[type];
#endif
}

const nurimc_message_spec *nurimc_spec(nurimc_message_type type) {
    static nurimc_message_spec copy;                                   /* used only with the tables in AVR flash */
    if ((unsigned)type >= (unsigned)NURIMC_MESSAGE_COUNT) return NULL; /* NONE is -1 or, with short enums, 255 */
    return spec_of(type, &copy);
}

nurimc_message_type nurimc_type_by_name(const char *name) {
    int i;
    if (name == NULL) return NURIMC_MSG_NONE;
    for (i = 0; i < (int)NURIMC_MESSAGE_COUNT; i++) {
        if (strcmp((const char *)NURIMC_TABLE_PTR(nurimc_message_specs[i].name), name) == 0) {
            return (nurimc_message_type)i;
        }
    }
    return NURIMC_MSG_NONE;
}

nurimc_message_type nurimc_type_by_mode(uint8_t mode) {
    uint8_t plus_one = NURIMC_TABLE_U8(nurimc_type_by_mode_plus_one[mode]);
    return plus_one ? (nurimc_message_type)(plus_one - 1) : NURIMC_MSG_NONE;
}

int nurimc_field_index(nurimc_message_type type, const char *name) {
    const nurimc_message_spec *spec = nurimc_spec(type);
    int i;
    if (spec == NULL || name == NULL) return -1;
    for (i = 0; i < spec->field_count; i++) {
        if (strcmp((const char *)NURIMC_TABLE_PTR(spec->fields[i].name), name) == 0) return i;
    }
    return -1;
}

int nurimc_baud_index(uint32_t baud) {
    int i;
    for (i = 0; i < (int)NURIMC_BAUD_RATE_COUNT; i++) {
        if (nurimc_baud_rates[i] == baud) return i;
    }
    return -1;
}

static const char *const status_names[] = {
    "ok",    "header", "truncated", "trailing", "checksum", "unknown_mode", "size",       "unknown_message",
    "range", "buffer", "argument",  "io",       "timeout",  "baud",         "not_finite", "fraction",
    "busy",
};

static const char *const status_texts[] = {
    "ok",
    "frame does not start with FF FE",
    "frame is truncated (fewer bytes than its size byte says)",
    "bytes after the end of the frame",
    "bad checksum",
    "no message has this mode",
    "size byte does not fit the message's layout",
    "unknown message type",
    "ID or field value out of range",
    "output buffer too small",
    "invalid argument",
    "I/O error (see errno)",
    "no answer before the deadline",
    "not one of the protocol's 18 baud rates",
    "value is not a finite number",
    "a whole number is needed",
    "the port is in use by another program: close that program first",
};

const char *nurimc_status_name(nurimc_status status) {
    if ((unsigned)status >= sizeof status_names / sizeof status_names[0]) return "unknown_status";
    return status_names[status];
}

const char *nurimc_status_text(nurimc_status status) {
    if ((unsigned)status >= sizeof status_texts / sizeof status_texts[0]) return "unknown status";
    return status_texts[status];
}

nurimc_message nurimc_message_init(nurimc_message_type type, uint8_t id) {
    nurimc_message msg;
    memset(&msg, 0, sizeof msg);
    msg.type = type;
    msg.id = id;
    return msg;
}

/* A field's row in the table (in AVR flash with NURIMC_TABLES_IN_FLASH: read it with the macros). */
static const nurimc_field_spec *field_of(nurimc_message_type type, int index) {
    nurimc_message_spec copy;
    const nurimc_message_spec *spec;
    if ((unsigned)type >= (unsigned)NURIMC_MESSAGE_COUNT) return NULL;
    spec = spec_of(type, &copy);
    if (index < 0 || index >= spec->field_count) return NULL;
    return &spec->fields[index];
}

/* The generated offsets point at a uint8_t or uint16_t member, so these accesses are well typed. */
static uint16_t read_field(const nurimc_message *msg, const nurimc_field_spec *f) {
    const unsigned char *at = (const unsigned char *)msg + NURIMC_TABLE_U16(f->offset);
    return NURIMC_TABLE_U8(f->width) == 1 ? *(const uint8_t *)at : *(const uint16_t *)(const void *)at;
}

static void write_field(nurimc_message *msg, const nurimc_field_spec *f, uint16_t value) {
    unsigned char *at = (unsigned char *)msg + NURIMC_TABLE_U16(f->offset);
    if (NURIMC_TABLE_U8(f->width) == 1) {
        *(uint8_t *)at = (uint8_t)value;
    } else {
        *(uint16_t *)(void *)at = value;
    }
}

uint16_t nurimc_get_field(const nurimc_message *msg, int index) {
    const nurimc_field_spec *f = msg ? field_of(msg->type, index) : NULL;
    return f ? read_field(msg, f) : 0;
}

nurimc_status nurimc_set_field(nurimc_message *msg, int index, uint16_t value) {
    const nurimc_field_spec *f = msg ? field_of(msg->type, index) : NULL;
    if (f == NULL) return NURIMC_E_ARGUMENT;
    if (NURIMC_TABLE_U8(f->width) == 1 && value > 0xFF) return NURIMC_E_RANGE;
    write_field(msg, f, value);
    return NURIMC_OK;
}

uint8_t nurimc_checksum(const uint8_t *frame, size_t length) {
    unsigned sum = 0;
    size_t i;
    for (i = ID_OFFSET; i < length; i++) {
        if (i != CHECKSUM_OFFSET) sum += frame[i];
    }
    return (uint8_t)(~sum & 0xFFu);
}

static void set_bad_field(int *bad_field, int value) {
    if (bad_field != NULL) *bad_field = value;
}

nurimc_status nurimc_encode(const nurimc_message *msg, uint8_t *out, size_t capacity, size_t *length, int *bad_field) {
    nurimc_message_spec copy;
    const nurimc_message_spec *spec;
    size_t at = DATA_OFFSET;
    int i;
    set_bad_field(bad_field, NURIMC_FIELD_NONE);
    if (msg == NULL || out == NULL) return NURIMC_E_ARGUMENT;
    if ((unsigned)msg->type >= (unsigned)NURIMC_MESSAGE_COUNT) return NURIMC_E_UNKNOWN_MESSAGE;
    spec = spec_of(msg->type, &copy);
    if (msg->id > spec->max_id) {
        set_bad_field(bad_field, NURIMC_FIELD_ID);
        return NURIMC_E_RANGE;
    }
    for (i = 0; i < spec->field_count; i++) {
        uint16_t value = read_field(msg, &spec->fields[i]);
        if (value < NURIMC_TABLE_U16(spec->fields[i].min) || value > NURIMC_TABLE_U16(spec->fields[i].max)) {
            set_bad_field(bad_field, i);
            return NURIMC_E_RANGE;
        }
    }
    if (capacity < (size_t)spec->size + NURIMC_FRAME_OVERHEAD) return NURIMC_E_BUFFER;
    out[0] = NURIMC_HEADER_0;
    out[1] = NURIMC_HEADER_1;
    out[ID_OFFSET] = msg->id;
    out[SIZE_OFFSET] = spec->size;
    out[MODE_OFFSET] = spec->mode;
    for (i = 0; i < spec->field_count; i++) {
        uint16_t value = read_field(msg, &spec->fields[i]);
        if (NURIMC_TABLE_U8(spec->fields[i].width) == 2) out[at++] = (uint8_t)(value >> 8);
        out[at++] = (uint8_t)(value & 0xFFu);
    }
    out[CHECKSUM_OFFSET] = nurimc_checksum(out, at);
    if (length != NULL) *length = at;
    return NURIMC_OK;
}

nurimc_status nurimc_encode_values(nurimc_message_type type, long id, const long *values, uint8_t *out, size_t capacity,
                                   size_t *length, int *bad_field) {
    nurimc_message_spec copy;
    const nurimc_message_spec *spec;
    nurimc_message msg;
    int i;
    set_bad_field(bad_field, NURIMC_FIELD_NONE);
    if ((unsigned)type >= (unsigned)NURIMC_MESSAGE_COUNT) return NURIMC_E_UNKNOWN_MESSAGE;
    spec = spec_of(type, &copy);
    if (id < 0 || id > (long)spec->max_id) {
        set_bad_field(bad_field, NURIMC_FIELD_ID);
        return NURIMC_E_RANGE;
    }
    if (spec->field_count > 0 && values == NULL) return NURIMC_E_ARGUMENT;
    msg = nurimc_message_init(type, (uint8_t)id);
    for (i = 0; i < spec->field_count; i++) {
        if (values[i] < (long)NURIMC_TABLE_U16(spec->fields[i].min) ||
            values[i] > (long)NURIMC_TABLE_U16(spec->fields[i].max)) {
            set_bad_field(bad_field, i);
            return NURIMC_E_RANGE;
        }
        write_field(&msg, &spec->fields[i], (uint16_t)values[i]);
    }
    return nurimc_encode(&msg, out, capacity, length, bad_field);
}

/* Fill `out` from a frame whose checks all passed. */
void nurimc_unpack_valid(const uint8_t *frame, nurimc_message_type type, nurimc_message *out);
void nurimc_unpack_valid(const uint8_t *frame, nurimc_message_type type, nurimc_message *out) {
    nurimc_message_spec copy;
    const nurimc_message_spec *spec = spec_of(type, &copy);
    size_t at = DATA_OFFSET;
    int i;
    *out = nurimc_message_init(type, frame[ID_OFFSET]);
    for (i = 0; i < spec->field_count; i++) {
        uint16_t value = frame[at++];
        if (NURIMC_TABLE_U8(spec->fields[i].width) == 2) value = (uint16_t)((value << 8) | frame[at++]);
        write_field(out, &spec->fields[i], value);
    }
}

nurimc_status nurimc_decode(const uint8_t *frame, size_t length, nurimc_message *out) {
    nurimc_message_type type;
    uint8_t size;
    if ((frame == NULL && length > 0) || out == NULL) return NURIMC_E_ARGUMENT;
    if ((length >= 1 && frame[0] != NURIMC_HEADER_0) || (length >= 2 && frame[1] != NURIMC_HEADER_1)) {
        return NURIMC_E_HEADER;
    }
    if (length < NURIMC_MIN_FRAME_LENGTH) return NURIMC_E_TRUNCATED;
    size = frame[SIZE_OFFSET];
    if (length < (size_t)size + NURIMC_FRAME_OVERHEAD) return NURIMC_E_TRUNCATED;
    if (length > (size_t)size + NURIMC_FRAME_OVERHEAD) return NURIMC_E_TRAILING;
    if (frame[CHECKSUM_OFFSET] != nurimc_checksum(frame, length)) return NURIMC_E_CHECKSUM;
    type = nurimc_type_by_mode(frame[MODE_OFFSET]);
    if (type == NURIMC_MSG_NONE) return NURIMC_E_UNKNOWN_MODE;
    if (size != NURIMC_TABLE_U8(nurimc_message_specs[type].size)) return NURIMC_E_SIZE;
    nurimc_unpack_valid(frame, type, out);
    return NURIMC_OK;
}
