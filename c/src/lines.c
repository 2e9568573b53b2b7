/* Product lines (spec/lines.json): encode, decode and scan with a line's message table.
 * The tables are generated (nurimc_lines_tables.c); the MC line is the table of <nurimc.h>,
 * so MC frames read the same here as with nurimc_decode. */
#include <string.h>

#include "nurimc_lines.h"

enum { ID_AT = 2, SIZE_AT = 3, CHECKSUM_AT = 4, MODE_AT = 5, DATA_AT = 6 };

int nurimc_line_by_name(const char *name) {
    int i;
    if (name == NULL) return -1;
    for (i = 0; i < (int)NURIMC_LINE_COUNT; i++) {
        if (strcmp(nurimc_line_specs[i].name, name) == 0) return i;
    }
    return -1;
}

static const nurimc_line_spec *line_spec(nurimc_line line) {
    return (unsigned)line < (unsigned)NURIMC_LINE_COUNT ? &nurimc_line_specs[line] : NULL;
}

const nurimc_message_spec *nurimc_line_message_spec(nurimc_line line, int index) {
    const nurimc_line_spec *spec = line_spec(line);
    if (spec == NULL || index < 0 || index >= (int)spec->message_count) return NULL;
    return &spec->messages[index];
}

int nurimc_line_message_index(nurimc_line line, const char *name) {
    const nurimc_line_spec *spec = line_spec(line);
    int i;
    if (spec == NULL || name == NULL) return -1;
    for (i = 0; i < (int)spec->message_count; i++) {
        if (strcmp(spec->messages[i].name, name) == 0) return i;
    }
    return -1;
}

nurimc_status nurimc_line_encode_values(nurimc_line line, int index, long id, const long *values, uint8_t *out,
                                        size_t capacity, size_t *length, int *bad_field) {
    const nurimc_message_spec *spec = nurimc_line_message_spec(line, index);
    size_t at = DATA_AT;
    int i;
    if (spec == NULL) return NURIMC_E_UNKNOWN_MESSAGE;
    if (out == NULL || (spec->field_count > 0 && values == NULL)) return NURIMC_E_ARGUMENT;
    if (id < 0 || id > (long)spec->max_id) {
        if (bad_field != NULL) *bad_field = NURIMC_FIELD_ID;
        return NURIMC_E_RANGE;
    }
    for (i = 0; i < spec->field_count; i++) {
        if (values[i] < (long)spec->fields[i].min || values[i] > (long)spec->fields[i].max) {
            if (bad_field != NULL) *bad_field = i;
            return NURIMC_E_RANGE;
        }
    }
    if (capacity < (size_t)spec->size + NURIMC_FRAME_OVERHEAD) return NURIMC_E_BUFFER;
    out[0] = NURIMC_HEADER_0;
    out[1] = NURIMC_HEADER_1;
    out[ID_AT] = (uint8_t)id;
    out[SIZE_AT] = spec->size;
    out[MODE_AT] = spec->mode;
    for (i = 0; i < spec->field_count; i++) {
        if (spec->fields[i].width == 2) out[at++] = (uint8_t)((unsigned long)values[i] >> 8);
        out[at++] = (uint8_t)((unsigned long)values[i] & 0xFFu);
    }
    out[CHECKSUM_AT] = nurimc_checksum(out, at);
    if (length != NULL) *length = at;
    if (bad_field != NULL) *bad_field = NURIMC_FIELD_NONE;
    return NURIMC_OK;
}

nurimc_status nurimc_line_decode(nurimc_line line, const uint8_t *frame, size_t length, nurimc_line_message *out) {
    const nurimc_line_spec *lspec = line_spec(line);
    const nurimc_message_spec *spec;
    uint8_t size, plus_one;
    size_t at = DATA_AT;
    int i;
    if (lspec == NULL || (frame == NULL && length > 0) || out == NULL) return NURIMC_E_ARGUMENT;
    if ((length >= 1 && frame[0] != NURIMC_HEADER_0) || (length >= 2 && frame[1] != NURIMC_HEADER_1)) {
        return NURIMC_E_HEADER;
    }
    if (length < NURIMC_MIN_FRAME_LENGTH) return NURIMC_E_TRUNCATED;
    size = frame[SIZE_AT];
    if (length < (size_t)size + NURIMC_FRAME_OVERHEAD) return NURIMC_E_TRUNCATED;
    if (length > (size_t)size + NURIMC_FRAME_OVERHEAD) return NURIMC_E_TRAILING;
    if (frame[CHECKSUM_AT] != nurimc_checksum(frame, length)) return NURIMC_E_CHECKSUM;
    plus_one = lspec->index_by_mode_plus_one[frame[MODE_AT]];
    if (plus_one == 0) return NURIMC_E_UNKNOWN_MODE;
    spec = &lspec->messages[plus_one - 1];
    if (size != spec->size) return NURIMC_E_SIZE;
    memset(out, 0, sizeof *out);
    out->line = line;
    out->index = (uint8_t)(plus_one - 1);
    out->id = frame[ID_AT];
    for (i = 0; i < spec->field_count; i++) {
        uint16_t value = frame[at++];
        if (spec->fields[i].width == 2) value = (uint16_t)((value << 8) | frame[at++]);
        out->values[i] = value;
    }
    return NURIMC_OK;
}

size_t nurimc_line_scan(nurimc_line line, const uint8_t *data, size_t length, nurimc_line_callback callback,
                        void *context, size_t *dropped) {
    size_t pos = 0, frames = 0, lost = 0;
    nurimc_line_message msg;
    while (pos < length) {
        size_t take = length - pos;
        if (take >= 4 && (size_t)data[pos + SIZE_AT] + NURIMC_FRAME_OVERHEAD < take) {
            take = (size_t)data[pos + SIZE_AT] + NURIMC_FRAME_OVERHEAD;
        }
        if (nurimc_line_decode(line, data + pos, take, &msg) == NURIMC_OK) {
            if (callback != NULL) callback(context, &msg);
            frames++;
            pos += take;
        } else {
            lost++;
            pos++;
        }
    }
    if (dropped != NULL) *dropped = lost;
    return frames;
}
