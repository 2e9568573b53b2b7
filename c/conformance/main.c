/* The C conformance program: JSON lines in, one JSON line out per line (conformance/README.md). */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json.h"
#include "nurimc.h"
#include "nurimc_lines.h"
#include "nurimc_host.h"
#include "nurimc_settings.h"
#include "nurimc_units.h"

typedef struct output {
    char *text;
    size_t length, capacity;
} output;

static void put(output *out, const char *text) {
    size_t n = strlen(text);
    if (out->length + n + 1 > out->capacity) {
        size_t capacity = (out->length + n + 1) * 2;
        char *grown = realloc(out->text, capacity);
        if (grown == NULL) {
            fputs("conformance: out of memory\n", stderr);
            exit(1);
        }
        out->text = grown;
        out->capacity = capacity;
    }
    memcpy(out->text + out->length, text, n + 1);
    out->length += n;
}

/* A JSON string of `length` bytes of UTF-8 (a NUL inside is written as \u0000). */
static void put_string_n(output *out, const char *text, size_t length) {
    char one[8];
    const char *end = text + length;
    put(out, "\"");
    for (; text < end; text++) {
        unsigned char c = (unsigned char)*text;
        if (c == '"' || c == '\\') {
            one[0] = '\\';
            one[1] = (char)c;
            one[2] = '\0';
        } else if (c < 0x20) {
            snprintf(one, sizeof one, "\\u%04x", c);
        } else {
            one[0] = (char)c;
            one[1] = '\0';
        }
        put(out, one);
    }
    put(out, "\"");
}

static void put_string(output *out, const char *text) {
    put_string_n(out, text, strlen(text));
}

static int put_error(output *out, const char *kind, const char *field) {
    put(out, "{\"error\":");
    put_string(out, kind);
    if (field != NULL) {
        put(out, ",\"field\":");
        put_string(out, field);
    }
    put(out, "}");
    return 0;
}

static void put_message(output *out, const nurimc_message *msg) {
    const nurimc_message_spec *spec = nurimc_spec(msg->type);
    char number[24];
    int i;
    snprintf(number, sizeof number, "%u", (unsigned)msg->id);
    put(out, "{\"id\":");
    put(out, number);
    put(out, ",\"message\":");
    put_string(out, spec->name);
    for (i = 0; i < spec->field_count; i++) {
        put(out, ",");
        put_string(out, spec->fields[i].name);
        snprintf(number, sizeof number, ":%u", (unsigned)nurimc_get_field(msg, i));
        put(out, number);
    }
    put(out, "}");
}

static int hex_value(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

/* Contiguous hex digit pairs -> bytes (malloc'd, *length set); NULL if not hex. */
static uint8_t *hex_bytes(const json_doc *doc, int node, size_t *length) {
    const char *text;
    size_t n, i;
    uint8_t *bytes;
    if (node < 0 || doc->nodes[node].type != JSON_STRING) return NULL;
    text = doc->nodes[node].text;
    n = doc->nodes[node].length; /* a NUL inside is no hex digit: the loop below refuses it */
    if (n % 2 != 0) return NULL;
    bytes = malloc(n / 2 + 1);
    if (bytes == NULL) return NULL;
    for (i = 0; i < n / 2; i++) {
        int hi = hex_value(text[2 * i]), lo = hex_value(text[2 * i + 1]);
        if (hi < 0 || lo < 0) {
            free(bytes);
            return NULL;
        }
        bytes[i] = (uint8_t)(hi * 16 + lo);
    }
    *length = n / 2;
    return bytes;
}

static void op_decode(output *out, const json_doc *doc) {
    size_t length = 0;
    uint8_t *bytes = hex_bytes(doc, json_member(doc, 0, "hex"), &length);
    nurimc_message msg;
    nurimc_status status;
    if (bytes == NULL) {
        put_error(out, "bad_hex", NULL);
        return;
    }
    status = nurimc_decode(bytes, length, &msg);
    free(bytes);
    if (status == NURIMC_OK) {
        put_message(out, &msg);
    } else {
        put_error(out, nurimc_status_name(status), NULL);
    }
}

static int is_integer(const json_doc *doc, int node) {
    return node >= 0 && doc->nodes[node].type == JSON_INT;
}

static int op_encode(output *out, const json_doc *doc) {
    int message_node = json_member(doc, 0, "message"), id_node = json_member(doc, 0, "id");
    const nurimc_message_spec *spec;
    nurimc_message_type type;
    long values[NURIMC_MAX_FIELDS];
    uint8_t frame[NURIMC_MAX_FRAME_LENGTH];
    size_t length = 0;
    int i, child, bad_field;
    nurimc_status status;
    char hex[2 * NURIMC_MAX_FRAME_LENGTH + 1];

    if (message_node < 0) return put_error(out, "missing_field", "message");
    if (id_node < 0) return put_error(out, "missing_field", "id");
    if (doc->nodes[message_node].type != JSON_STRING) return put_error(out, "unknown_message", NULL);
    /* A name with a NUL inside is no message name (the library sees C strings). */
    if (strlen(doc->nodes[message_node].text) != doc->nodes[message_node].length) {
        return put_error(out, "unknown_message", NULL);
    }
    type = nurimc_type_by_name(doc->nodes[message_node].text);
    spec = nurimc_spec(type);
    if (spec == NULL) return put_error(out, "unknown_message", NULL);
    for (i = 0; i < spec->field_count; i++) {
        if (json_member(doc, 0, spec->fields[i].name) < 0) return put_error(out, "missing_field", spec->fields[i].name);
    }
    for (child = doc->nodes[0].first_child; child >= 0; child = doc->nodes[child].next_sibling) {
        const char *key = doc->nodes[child].key;
        size_t key_length = doc->nodes[child].key_length;
        if (strlen(key) == key_length && (strcmp(key, "op") == 0 || strcmp(key, "id") == 0 ||
                                          strcmp(key, "message") == 0 || strcmp(key, "line") == 0)) {
            continue;
        }
        if (strlen(key) != key_length || nurimc_field_index(type, key) < 0) {
            put(out, "{\"error\":\"unknown_field\",\"field\":");
            put_string_n(out, key, key_length);
            put(out, "}");
            return 0;
        }
    }
    /* Type and range are checked field by field in wire order, the ID first. */
    if (!is_integer(doc, id_node)) return put_error(out, "type", "id");
    if (doc->nodes[id_node].value < 0 || doc->nodes[id_node].value > spec->max_id) {
        return put_error(out, "range", "id");
    }
    for (i = 0; i < spec->field_count; i++) {
        int node = json_member(doc, 0, spec->fields[i].name);
        if (!is_integer(doc, node)) return put_error(out, "type", spec->fields[i].name);
        values[i] = doc->nodes[node].value;
        if (values[i] < spec->fields[i].min || values[i] > spec->fields[i].max) {
            return put_error(out, "range", spec->fields[i].name);
        }
    }
    status = nurimc_encode_values(type, doc->nodes[id_node].value, values, frame, sizeof frame, &length, &bad_field);
    if (status != NURIMC_OK) {
        /* The checks above mirror the library's; reaching here means they disagree. */
        const char *field = bad_field == NURIMC_FIELD_ID ? "id" : bad_field >= 0 ? spec->fields[bad_field].name : NULL;
        return put_error(out, nurimc_status_name(status), field);
    }
    for (i = 0; i < (int)length; i++) snprintf(hex + 2 * i, 3, "%02x", frame[i]);
    put(out, "{\"hex\":\"");
    put(out, hex);
    put(out, "\"}");
    return 0;
}

typedef struct collected {
    output frames;
    int count;
} collected;

static void collect(void *context, const nurimc_message *msg) {
    collected *c = context;
    if (c->count++ > 0) put(&c->frames, ",");
    put_message(&c->frames, msg);
}

static int feed_hex(nurimc_parser *parser, const json_doc *doc, int node, collected *c) {
    size_t length = 0;
    uint8_t *bytes = hex_bytes(doc, node, &length);
    if (bytes == NULL) return -1;
    nurimc_parser_feed(parser, bytes, length, collect, c);
    free(bytes);
    return 0;
}

static int op_parse(output *out, const json_doc *doc) {
    int chunks = json_member(doc, 0, "chunks");
    nurimc_parser parser;
    nurimc_message msg;
    collected c;
    char number[32];
    int bad = 0;
    memset(&c, 0, sizeof c);
    nurimc_parser_init(&parser);
    if (chunks < 0 || doc->nodes[chunks].type == JSON_NULL) {
        bad = feed_hex(&parser, doc, json_member(doc, 0, "hex"), &c);
    } else if (doc->nodes[chunks].type != JSON_ARRAY) {
        bad = -1;
    } else {
        int chunk;
        for (chunk = doc->nodes[chunks].first_child; chunk >= 0 && !bad; chunk = doc->nodes[chunk].next_sibling) {
            bad = feed_hex(&parser, doc, chunk, &c);
        }
    }
    if (bad) {
        free(c.frames.text);
        return put_error(out, "bad_hex", NULL);
    }
    while (nurimc_parser_finish(&parser, &msg)) collect(&c, &msg);
    put(out, "{\"frames\":[");
    if (c.frames.text != NULL) put(out, c.frames.text);
    snprintf(number, sizeof number, "%lu", (unsigned long)parser.stats.dropped_bytes);
    put(out, "],\"dropped_bytes\":");
    put(out, number);
    put(out, "}");
    free(c.frames.text);
    return 0;
}

/* ---- product lines (spec/lines.json): "line" names the table; MC when absent ------------ */

/* The request's line: NURIMC_LINE_MC when absent, -1 when "line" names no line. */
static int request_line(const json_doc *doc) {
    int node = json_member(doc, 0, "line");
    if (node < 0) return NURIMC_LINE_MC;
    if (doc->nodes[node].type != JSON_STRING || strlen(doc->nodes[node].text) != doc->nodes[node].length) return -1;
    return nurimc_line_by_name(doc->nodes[node].text);
}

static void put_line_message(output *out, const nurimc_line_message *msg) {
    const nurimc_message_spec *spec = nurimc_line_message_spec(msg->line, msg->index);
    char number[24];
    int i;
    snprintf(number, sizeof number, "%u", (unsigned)msg->id);
    put(out, "{\"id\":");
    put(out, number);
    put(out, ",\"message\":");
    put_string(out, spec->name);
    for (i = 0; i < spec->field_count; i++) {
        put(out, ",");
        put_string(out, spec->fields[i].name);
        snprintf(number, sizeof number, ":%u", (unsigned)msg->values[i]);
        put(out, number);
    }
    put(out, "}");
}

static void op_line_decode(output *out, const json_doc *doc, nurimc_line line) {
    size_t length = 0;
    uint8_t *bytes = hex_bytes(doc, json_member(doc, 0, "hex"), &length);
    nurimc_line_message msg;
    nurimc_status status;
    if (bytes == NULL) {
        put_error(out, "bad_hex", NULL);
        return;
    }
    status = nurimc_line_decode(line, bytes, length, &msg);
    free(bytes);
    if (status == NURIMC_OK) {
        put_line_message(out, &msg);
    } else {
        put_error(out, nurimc_status_name(status), NULL);
    }
}

static int op_line_encode(output *out, const json_doc *doc, nurimc_line line) {
    int message_node = json_member(doc, 0, "message"), id_node = json_member(doc, 0, "id");
    const nurimc_message_spec *spec;
    long values[NURIMC_MAX_FIELDS];
    uint8_t frame[NURIMC_MAX_FRAME_LENGTH];
    size_t length = 0;
    int i, child, index, bad_field;
    nurimc_status status;
    char hex[2 * NURIMC_MAX_FRAME_LENGTH + 1];

    if (message_node < 0) return put_error(out, "missing_field", "message");
    if (id_node < 0) return put_error(out, "missing_field", "id");
    if (doc->nodes[message_node].type != JSON_STRING ||
        strlen(doc->nodes[message_node].text) != doc->nodes[message_node].length) {
        return put_error(out, "unknown_message", NULL);
    }
    index = nurimc_line_message_index(line, doc->nodes[message_node].text);
    spec = nurimc_line_message_spec(line, index);
    if (spec == NULL) return put_error(out, "unknown_message", NULL);
    for (i = 0; i < spec->field_count; i++) {
        if (json_member(doc, 0, spec->fields[i].name) < 0) return put_error(out, "missing_field", spec->fields[i].name);
    }
    for (child = doc->nodes[0].first_child; child >= 0; child = doc->nodes[child].next_sibling) {
        const char *key = doc->nodes[child].key;
        size_t key_length = doc->nodes[child].key_length;
        int known = 0;
        if (strlen(key) == key_length) {
            known = strcmp(key, "op") == 0 || strcmp(key, "id") == 0 || strcmp(key, "message") == 0 ||
                    strcmp(key, "line") == 0;
            for (i = 0; i < spec->field_count && !known; i++) known = strcmp(key, spec->fields[i].name) == 0;
        }
        if (!known) {
            put(out, "{\"error\":\"unknown_field\",\"field\":");
            put_string_n(out, key, key_length);
            put(out, "}");
            return 0;
        }
    }
    if (!is_integer(doc, id_node)) return put_error(out, "type", "id");
    if (doc->nodes[id_node].value < 0 || doc->nodes[id_node].value > spec->max_id) return put_error(out, "range", "id");
    for (i = 0; i < spec->field_count; i++) {
        int node = json_member(doc, 0, spec->fields[i].name);
        if (!is_integer(doc, node)) return put_error(out, "type", spec->fields[i].name);
        values[i] = doc->nodes[node].value;
        if (values[i] < spec->fields[i].min || values[i] > spec->fields[i].max) {
            return put_error(out, "range", spec->fields[i].name);
        }
    }
    status = nurimc_line_encode_values(line, index, doc->nodes[id_node].value, values, frame, sizeof frame, &length,
                                       &bad_field);
    if (status != NURIMC_OK) return put_error(out, nurimc_status_name(status), NULL);
    for (i = 0; i < (int)length; i++) snprintf(hex + 2 * i, 3, "%02x", frame[i]);
    put(out, "{\"hex\":\"");
    put(out, hex);
    put(out, "\"}");
    return 0;
}

typedef struct line_collected {
    output frames;
    int count;
} line_collected;

static void line_collect(void *context, const nurimc_line_message *msg) {
    line_collected *c = context;
    if (c->count++ > 0) put(&c->frames, ",");
    put_line_message(&c->frames, msg);
}

/* Appends the bytes of hex node `node` to *all (realloc'd); -1 if not hex. */
static int append_hex(const json_doc *doc, int node, uint8_t **all, size_t *total) {
    size_t length = 0;
    uint8_t *bytes = hex_bytes(doc, node, &length), *grown;
    if (bytes == NULL) return -1;
    grown = realloc(*all, *total + length + 1);
    if (grown == NULL) {
        free(bytes);
        return -1;
    }
    memcpy(grown + *total, bytes, length);
    *all = grown;
    *total += length;
    free(bytes);
    return 0;
}

static int op_line_parse(output *out, const json_doc *doc, nurimc_line line) {
    int chunks = json_member(doc, 0, "chunks"), bad = 0;
    uint8_t *all = NULL;
    size_t total = 0, dropped = 0;
    line_collected c;
    char number[32];
    memset(&c, 0, sizeof c);
    if (chunks < 0 || doc->nodes[chunks].type == JSON_NULL) {
        bad = append_hex(doc, json_member(doc, 0, "hex"), &all, &total);
    } else if (doc->nodes[chunks].type != JSON_ARRAY) {
        bad = -1;
    } else {
        int chunk;
        for (chunk = doc->nodes[chunks].first_child; chunk >= 0 && !bad; chunk = doc->nodes[chunk].next_sibling) {
            bad = append_hex(doc, chunk, &all, &total);
        }
    }
    if (bad) {
        free(all);
        return put_error(out, "bad_hex", NULL);
    }
    nurimc_line_scan(line, all, total, line_collect, &c, &dropped);
    free(all);
    put(out, "{\"frames\":[");
    if (c.frames.text != NULL) put(out, c.frames.text);
    snprintf(number, sizeof number, "%lu", (unsigned long)dropped);
    put(out, "],\"dropped_bytes\":");
    put(out, number);
    put(out, "}");
    free(c.frames.text);
    return 0;
}

/* 1 if s[0..n) is UTF-8 as RFC 3629 has it: no overlong forms, no surrogates, at most U+10FFFF. */
static int is_utf8(const unsigned char *s, size_t n) {
    size_t i = 0;
    while (i < n) {
        unsigned c = s[i], need, min, cp, k;
        if (c < 0x80) {
            i++;
            continue;
        }
        if (c >= 0xC2 && c <= 0xDF) {
            need = 1, min = 0x80, cp = c & 0x1F;
        } else if (c >= 0xE0 && c <= 0xEF) {
            need = 2, min = 0x800, cp = c & 0x0F;
        } else if (c >= 0xF0 && c <= 0xF4) {
            need = 3, min = 0x10000, cp = c & 0x07;
        } else {
            return 0;
        }
        if (n - i <= need) return 0;
        for (k = 1; k <= need; k++) {
            if ((s[i + k] & 0xC0) != 0x80) return 0;
            cp = (cp << 6) | (s[i + k] & 0x3F);
        }
        if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return 0;
        i += need + 1;
    }
    return 1;
}

/* ---- units: physical values <-> wire integers (conformance/README.md, "units") ----
 * The rule is the library's (nurimc_units.h); this maps the names and the answers. */

typedef enum quantity_kind { QUANTITY_DEGREES, QUANTITY_RPM, QUANTITY_SECONDS, QUANTITY_SETTING } quantity_kind;

typedef struct quantity {
    quantity_kind kind;
    const nurimc_setting *setting; /* QUANTITY_SETTING */
} quantity;

/* The request's quantity, by its exact name; -1 if there is none such. */
static int find_quantity(const json_doc *doc, quantity *q) {
    int node = json_member(doc, 0, "quantity");
    const json_node *n;
    if (node < 0 || doc->nodes[node].type != JSON_STRING) return -1;
    n = &doc->nodes[node];
    if (strlen(n->text) != n->length) return -1; /* a NUL inside names nothing */
    q->setting = NULL;
    if (strcmp(n->text, "degrees") == 0) {
        q->kind = QUANTITY_DEGREES;
    } else if (strcmp(n->text, "rpm") == 0) {
        q->kind = QUANTITY_RPM;
    } else if (strcmp(n->text, "seconds") == 0) {
        q->kind = QUANTITY_SECONDS;
    } else {
        q->kind = QUANTITY_SETTING;
        q->setting = nurimc_setting_by_name(n->text);
        if (q->setting == NULL) return -1;
    }
    return 0;
}

static void op_to_wire(output *out, const json_doc *doc) {
    quantity q;
    int node = json_member(doc, 0, "value");
    uint16_t wire = 0;
    uint8_t direction = 0;
    nurimc_status status;
    char text[64];
    if (find_quantity(doc, &q) != 0) {
        put_error(out, "unknown_quantity", NULL);
        return;
    }
    if (node >= 0 && doc->nodes[node].type == JSON_STRING && q.setting != NULL &&
        q.setting->input == NURIMC_INPUT_CHOICE) {
        /* a NUL inside a name matches no name */
        status = strlen(doc->nodes[node].text) != doc->nodes[node].length
                     ? NURIMC_E_RANGE
                     : nurimc_setting_choice_to_wire(q.setting, doc->nodes[node].text, &wire);
    } else if (node < 0 || (doc->nodes[node].type != JSON_INT && doc->nodes[node].type != JSON_FLOAT)) {
        put_error(out, "type", NULL);
        return;
    } else if (q.kind == QUANTITY_DEGREES) {
        status = nurimc_degrees_to_wire(doc->nodes[node].number, &wire, &direction);
    } else if (q.kind == QUANTITY_RPM) {
        status = nurimc_rpm_to_wire(doc->nodes[node].number, &wire, &direction);
    } else if (q.kind == QUANTITY_SECONDS) {
        status = nurimc_seconds_to_wire(doc->nodes[node].number, &wire);
    } else {
        status = nurimc_setting_to_wire(q.setting, doc->nodes[node].number, &wire);
    }
    if (status != NURIMC_OK) { /* out of range, not finite, a fraction: all `range` here */
        put_error(out, "range", NULL);
        return;
    }
    if (q.kind == QUANTITY_DEGREES || q.kind == QUANTITY_RPM) {
        snprintf(text, sizeof text, "{\"direction\":%u,\"wire\":%u}", (unsigned)direction, (unsigned)wire);
    } else {
        snprintf(text, sizeof text, "{\"wire\":%u}", (unsigned)wire);
    }
    put(out, text);
}

/* A JSON integer node in 0..max: 0 and *value; else the error kind. */
static const char *integer_in(const json_doc *doc, int node, long max, long *value) {
    if (!is_integer(doc, node)) return "type";
    if (doc->nodes[node].value < 0 || doc->nodes[node].value > max) return "range";
    *value = doc->nodes[node].value;
    return NULL;
}

/* The scale of a motion quantity: its field in the generated message table. */
static const nurimc_field_spec *motion_field(quantity_kind kind) {
    nurimc_message_type type = kind == QUANTITY_DEGREES ? NURIMC_MSG_POSITION_SPEED : NURIMC_MSG_ACCEL_SPEED;
    const char *name = kind == QUANTITY_DEGREES ? "position" : kind == QUANTITY_RPM ? "speed" : "arrival_time";
    int index = nurimc_field_index(type, name);
    if (index < 0) {
        fprintf(stderr, "conformance: no field %s\n", name);
        exit(1);
    }
    return &nurimc_spec(type)->fields[index];
}

static void op_from_wire(output *out, const json_doc *doc) {
    quantity q;
    long wire = 0, direction = 0;
    uint32_t num, den;
    const char *error, *name = NULL;
    char text[48];
    if (find_quantity(doc, &q) != 0) {
        put_error(out, "unknown_quantity", NULL);
        return;
    }
    error = integer_in(doc, json_member(doc, 0, "wire"), 65535, &wire);
    if (error == NULL && (q.kind == QUANTITY_DEGREES || q.kind == QUANTITY_RPM)) {
        error = integer_in(doc, json_member(doc, 0, "direction"), 1, &direction);
    }
    if (error != NULL) {
        put_error(out, error, NULL);
        return;
    }
    if (q.setting != NULL) {
        num = q.setting->scale_num;
        den = q.setting->scale_den;
        name = nurimc_setting_choice_name(q.setting, (uint16_t)wire);
    } else {
        num = motion_field(q.kind)->scale_num;
        den = motion_field(q.kind)->scale_den;
    }
    put(out, "{\"value\":");
    if (name != NULL) {
        put_string(out, name);
    } else if (nurimc_units_format(wire, num, den, direction == 1 && wire != 0, text, sizeof text, NULL) == NURIMC_OK) {
        /* zero has no sign: direction 1 with wire 0 is 0, never -0 (conformance/README.md) */
        put(out, text);
    } else {
        fputs("conformance: a wire value that does not format\n", stderr);
        exit(1);
    }
    put(out, "}");
}

static void bad_request(output *out, const char *detail) {
    put(out, "{\"error\":\"bad_request\",\"detail\":");
    put_string(out, detail);
    put(out, "}");
}

/* The answer to one line of `n` bytes (without its newline; line[n] is a NUL the reader adds). */
static void answer(output *out, char *line, size_t n) {
    json_doc doc;
    int op;
    size_t i, blank = 1;
    for (i = 0; i < n; i++) {
        if (line[i] != ' ' && line[i] != '\t' && line[i] != '\r') blank = 0;
    }
    memset(&doc, 0, sizeof doc);
    if (blank) {
        bad_request(out, "empty line");
    } else if (memchr(line, '\0', n) != NULL) {
        bad_request(out, "a NUL byte is never JSON");
    } else if (!is_utf8((const unsigned char *)line, n)) {
        bad_request(out, "not UTF-8");
    } else if (json_parse(&doc, line) != 0) {
        put(out, "{\"error\":\"bad_request\",\"detail\":");
        put_string(out, doc.error[0] ? doc.error : "not JSON");
        put(out, "}");
    } else if (doc.nodes[0].type != JSON_OBJECT) {
        put(out, "{\"error\":\"bad_request\",\"detail\":\"each line must be a JSON object\"}");
    } else {
        int product_line;
        op = json_member(&doc, 0, "op");
        product_line = request_line(&doc);
        if (product_line < 0 && (json_string_is(&doc, op, "decode") || json_string_is(&doc, op, "encode") ||
                                 json_string_is(&doc, op, "parse"))) {
            put_error(out, "unknown_line", NULL);
        } else if (product_line != NURIMC_LINE_MC && json_string_is(&doc, op, "decode")) {
            op_line_decode(out, &doc, (nurimc_line)product_line);
        } else if (product_line != NURIMC_LINE_MC && json_string_is(&doc, op, "encode")) {
            op_line_encode(out, &doc, (nurimc_line)product_line);
        } else if (product_line != NURIMC_LINE_MC && json_string_is(&doc, op, "parse")) {
            op_line_parse(out, &doc, (nurimc_line)product_line);
        } else if (json_string_is(&doc, op, "decode")) {
            op_decode(out, &doc);
        } else if (json_string_is(&doc, op, "encode")) {
            op_encode(out, &doc);
        } else if (json_string_is(&doc, op, "parse")) {
            op_parse(out, &doc);
        } else if (json_string_is(&doc, op, "to_wire")) {
            op_to_wire(out, &doc);
        } else if (json_string_is(&doc, op, "from_wire")) {
            op_from_wire(out, &doc);
        } else {
            put_error(out, "unknown_op", NULL);
        }
    }
    json_free(&doc);
}

/* Reads one line (LF ends it; a last unterminated line counts) into *line, at most
 * MAX_LINE_BYTES kept: a longer line is read past and *overlong set. Returns 0 at end of input. */
#define MAX_LINE_BYTES (4u * 1024u * 1024u)

static int read_line(char **line, size_t *capacity, size_t *length, int *overlong) {
    int c, any = 0;
    size_t n = 0;
    *overlong = 0;
    while ((c = getchar()) != EOF) {
        any = 1;
        if (c == '\n') break;
        if (n == MAX_LINE_BYTES) {
            *overlong = 1;
            continue;
        }
        if (n + 1 >= *capacity) {
            size_t grown_capacity = *capacity ? *capacity * 2 : 4096;
            char *grown = realloc(*line, grown_capacity);
            if (grown == NULL) {
                fputs("conformance: out of memory\n", stderr);
                exit(1);
            }
            *line = grown;
            *capacity = grown_capacity;
        }
        (*line)[n++] = (char)c;
    }
    if (!any) return 0;
    if (*line == NULL) {
        *line = malloc(1);
        if (*line == NULL) exit(1);
        *capacity = 1;
    }
    (*line)[n] = '\0';
    *length = n;
    return 1;
}

int main(void) {
    char *line = NULL;
    size_t capacity = 0, length = 0;
    int overlong = 0;
    output out = {NULL, 0, 0};
    while (read_line(&line, &capacity, &length, &overlong)) {
        out.length = 0;
        put(&out, "");
        if (overlong) {
            bad_request(&out, "line longer than 4194304 bytes");
        } else {
            answer(&out, line, length);
        }
        put(&out, "\n");
        fwrite(out.text, 1, out.length, stdout);
        fflush(stdout);
    }
    free(line);
    free(out.text);
    return 0;
}
