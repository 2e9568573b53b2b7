/* The C conformance program: JSON lines in, one JSON line out per line (conformance/README.md). */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json.h"
#include "nurimc.h"

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

static void put_string(output *out, const char *text) {
    char one[8];
    put(out, "\"");
    for (; *text; text++) {
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
    n = strlen(text);
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
    type = nurimc_type_by_name(doc->nodes[message_node].text);
    spec = nurimc_spec(type);
    if (spec == NULL) return put_error(out, "unknown_message", NULL);
    for (i = 0; i < spec->field_count; i++) {
        if (json_member(doc, 0, spec->fields[i].name) < 0) return put_error(out, "missing_field", spec->fields[i].name);
    }
    for (child = doc->nodes[0].first_child; child >= 0; child = doc->nodes[child].next_sibling) {
        const char *key = doc->nodes[child].key;
        if (strcmp(key, "op") == 0 || strcmp(key, "id") == 0 || strcmp(key, "message") == 0) continue;
        if (nurimc_field_index(type, key) < 0) return put_error(out, "unknown_field", key);
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

static void answer(output *out, char *line) {
    json_doc doc;
    int op;
    memset(&doc, 0, sizeof doc);
    if (json_parse(&doc, line) != 0) {
        put(out, "{\"error\":\"bad_request\",\"detail\":");
        put_string(out, doc.error[0] ? doc.error : "not JSON");
        put(out, "}");
    } else if (doc.nodes[0].type != JSON_OBJECT) {
        put(out, "{\"error\":\"bad_request\",\"detail\":\"each line must be a JSON object\"}");
    } else {
        op = json_member(&doc, 0, "op");
        if (op >= 0 && doc.nodes[op].type == JSON_STRING && strcmp(doc.nodes[op].text, "decode") == 0) {
            op_decode(out, &doc);
        } else if (op >= 0 && doc.nodes[op].type == JSON_STRING && strcmp(doc.nodes[op].text, "encode") == 0) {
            op_encode(out, &doc);
        } else if (op >= 0 && doc.nodes[op].type == JSON_STRING && strcmp(doc.nodes[op].text, "parse") == 0) {
            op_parse(out, &doc);
        } else {
            put_error(out, "unknown_op", NULL);
        }
    }
    json_free(&doc);
}

int main(void) {
    char *line = NULL;
    size_t capacity = 0;
    ssize_t n;
    output out = {NULL, 0, 0};
    while ((n = getline(&line, &capacity, stdin)) >= 0) {
        size_t i, blank = 1;
        for (i = 0; i < (size_t)n; i++) {
            if (line[i] != ' ' && line[i] != '\t' && line[i] != '\n' && line[i] != '\r') blank = 0;
        }
        if (blank) continue;
        out.length = 0;
        put(&out, "");
        answer(&out, line);
        put(&out, "\n");
        fputs(out.text, stdout);
        fflush(stdout);
    }
    free(line);
    free(out.text);
    return 0;
}
