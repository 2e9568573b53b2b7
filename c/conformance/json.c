/* A minimal strict JSON reader: enough for one conformance request per line. */
#include "json.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct reader {
    json_doc *doc;
    char *at;
    int depth;
} reader;

static int fail(reader *r, const char *what) {
    snprintf(r->doc->error, sizeof r->doc->error, "%s at offset-from-end %zu", what, strlen(r->at));
    return -1;
}

static void skip_space(reader *r) {
    while (*r->at == ' ' || *r->at == '\t' || *r->at == '\n' || *r->at == '\r') r->at++;
}

static int new_node(reader *r, json_type type) {
    json_doc *doc = r->doc;
    if (doc->count == doc->capacity) {
        int capacity = doc->capacity ? doc->capacity * 2 : 64;
        json_node *grown = realloc(doc->nodes, (size_t)capacity * sizeof *grown);
        if (grown == NULL) return -1;
        doc->nodes = grown;
        doc->capacity = capacity;
    }
    memset(&doc->nodes[doc->count], 0, sizeof doc->nodes[0]);
    doc->nodes[doc->count].type = type;
    doc->nodes[doc->count].first_child = -1;
    doc->nodes[doc->count].next_sibling = -1;
    return doc->count++;
}

static int hex_digit(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

static int read_hex4(const char *p, unsigned *out) {
    int i;
    *out = 0;
    for (i = 0; i < 4; i++) {
        int d = hex_digit(p[i]);
        if (d < 0) return -1;
        *out = *out * 16u + (unsigned)d;
    }
    return 0;
}

static char *put_utf8(char *w, unsigned cp) {
    if (cp < 0x80) {
        *w++ = (char)cp;
    } else if (cp < 0x800) {
        *w++ = (char)(0xC0 | (cp >> 6));
        *w++ = (char)(0x80 | (cp & 0x3F));
    } else if (cp < 0x10000) {
        *w++ = (char)(0xE0 | (cp >> 12));
        *w++ = (char)(0x80 | ((cp >> 6) & 0x3F));
        *w++ = (char)(0x80 | (cp & 0x3F));
    } else {
        *w++ = (char)(0xF0 | (cp >> 18));
        *w++ = (char)(0x80 | ((cp >> 12) & 0x3F));
        *w++ = (char)(0x80 | ((cp >> 6) & 0x3F));
        *w++ = (char)(0x80 | (cp & 0x3F));
    }
    return w;
}

/* Unescape the string at r->at (after the opening quote) in place; returns its start and
 * sets *length (a \u0000 is kept, so the length is not strlen). */
static char *read_string(reader *r, size_t *length) {
    char *start = r->at, *w = r->at;
    for (;;) {
        char c = *r->at;
        if (c == '\0' || (unsigned char)c < 0x20) return NULL;
        r->at++;
        if (c == '"') break;
        if (c != '\\') {
            *w++ = c;
            continue;
        }
        c = *r->at++;
        switch (c) {
        case '"': *w++ = '"'; break;
        case '\\': *w++ = '\\'; break;
        case '/': *w++ = '/'; break;
        case 'b': *w++ = '\b'; break;
        case 'f': *w++ = '\f'; break;
        case 'n': *w++ = '\n'; break;
        case 'r': *w++ = '\r'; break;
        case 't': *w++ = '\t'; break;
        case 'u': {
            unsigned cp, low;
            if (read_hex4(r->at, &cp) != 0) return NULL;
            r->at += 4;
            if (cp >= 0xDC00 && cp < 0xE000) return NULL; /* a lone low surrogate */
            if (cp >= 0xD800 && cp < 0xDC00) {
                if (!(r->at[0] == '\\' && r->at[1] == 'u' && read_hex4(r->at + 2, &low) == 0 && low >= 0xDC00 &&
                      low < 0xE000)) {
                    return NULL; /* a lone high surrogate */
                }
                cp = 0x10000 + ((cp - 0xD800) << 10) + (low - 0xDC00);
                r->at += 6;
            }
            w = put_utf8(w, cp);
            break;
        }
        default: return NULL;
        }
    }
    *w = '\0'; /* w < r->at here: the closing quote's place is free at least */
    *length = (size_t)(w - start);
    return start;
}

static int read_value(reader *r);

static int read_number(reader *r) {
    char *p = r->at, *start = r->at;
    int is_float = 0, negative = 0, node;
    long value = 0;
    int saturated = 0;
    if (*p == '-') {
        negative = 1;
        p++;
    }
    if (*p == '0') {
        p++;
    } else if (*p >= '1' && *p <= '9') {
        for (; *p >= '0' && *p <= '9'; p++) {
            int d = *p - '0';
            if (!saturated && value > (LONG_MAX - d) / 10) saturated = 1;
            if (!saturated) value = value * 10 + d;
        }
    } else {
        return fail(r, "bad number");
    }
    if (*p == '.') {
        is_float = 1;
        p++;
        if (!(*p >= '0' && *p <= '9')) return fail(r, "bad number");
        while (*p >= '0' && *p <= '9') p++;
    }
    if (*p == 'e' || *p == 'E') {
        is_float = 1;
        p++;
        if (*p == '+' || *p == '-') p++;
        if (!(*p >= '0' && *p <= '9')) return fail(r, "bad number");
        while (*p >= '0' && *p <= '9') p++;
    }
    r->at = p;
    node = new_node(r, is_float ? JSON_FLOAT : JSON_INT);
    if (node < 0) return fail(r, "out of memory");
    if (saturated) value = LONG_MAX;
    r->doc->nodes[node].value = negative ? -value : value;
    r->doc->nodes[node].number = strtod(start, NULL);
    return node;
}

static int read_literal(reader *r, const char *word, json_type type, long value) {
    size_t n = strlen(word);
    int node;
    if (strncmp(r->at, word, n) != 0) return fail(r, "unexpected character");
    r->at += n;
    node = new_node(r, type);
    if (node < 0) return fail(r, "out of memory");
    r->doc->nodes[node].value = value;
    return node;
}

static int read_container(reader *r, int is_object) {
    char close = is_object ? '}' : ']';
    int node = new_node(r, is_object ? JSON_OBJECT : JSON_ARRAY), last = -1;
    if (node < 0) return fail(r, "out of memory");
    if (++r->depth > JSON_MAX_DEPTH) return fail(r, "nested too deep");
    r->at++;
    skip_space(r);
    if (*r->at == close) {
        r->at++;
        r->depth--;
        return node;
    }
    for (;;) {
        const char *key = NULL;
        size_t key_length = 0;
        int child;
        skip_space(r);
        if (is_object) {
            if (*r->at != '"') return fail(r, "expected a member name");
            r->at++;
            key = read_string(r, &key_length);
            if (key == NULL) return fail(r, "bad string");
            skip_space(r);
            if (*r->at != ':') return fail(r, "expected ':'");
            r->at++;
        }
        child = read_value(r);
        if (child < 0) return -1;
        r->doc->nodes[child].key = key;
        r->doc->nodes[child].key_length = key_length;
        if (last < 0) {
            r->doc->nodes[node].first_child = child;
        } else {
            r->doc->nodes[last].next_sibling = child;
        }
        last = child;
        skip_space(r);
        if (*r->at == ',') {
            r->at++;
            continue;
        }
        if (*r->at == close) {
            r->at++;
            r->depth--;
            return node;
        }
        return fail(r, is_object ? "expected ',' or '}'" : "expected ',' or ']'");
    }
}

static int read_value(reader *r) {
    skip_space(r);
    switch (*r->at) {
    case '{': return read_container(r, 1);
    case '[': return read_container(r, 0);
    case '"': {
        int node;
        char *text;
        size_t length = 0;
        r->at++;
        text = read_string(r, &length);
        if (text == NULL) return fail(r, "bad string");
        node = new_node(r, JSON_STRING);
        if (node < 0) return fail(r, "out of memory");
        r->doc->nodes[node].text = text;
        r->doc->nodes[node].length = length;
        return node;
    }
    case 't': return read_literal(r, "true", JSON_BOOL, 1);
    case 'f': return read_literal(r, "false", JSON_BOOL, 0);
    case 'n': return read_literal(r, "null", JSON_NULL, 0);
    default: return read_number(r);
    }
}

int json_parse(json_doc *doc, char *text) {
    reader r;
    doc->count = 0;
    doc->error[0] = '\0';
    r.doc = doc;
    r.at = text;
    r.depth = 0;
    if (read_value(&r) < 0) return -1;
    skip_space(&r);
    if (*r.at != '\0') return fail(&r, "extra data after the value");
    return 0;
}

void json_free(json_doc *doc) {
    free(doc->nodes);
    doc->nodes = NULL;
    doc->count = doc->capacity = 0;
}

int json_member(const json_doc *doc, int object, const char *key) {
    int child, found = -1;
    size_t n = strlen(key);
    if (object < 0 || doc->nodes[object].type != JSON_OBJECT) return -1;
    for (child = doc->nodes[object].first_child; child >= 0; child = doc->nodes[child].next_sibling) {
        if (doc->nodes[child].key_length == n && memcmp(doc->nodes[child].key, key, n) == 0) found = child;
    }
    return found;
}

int json_string_is(const json_doc *doc, int node, const char *word) {
    size_t n = strlen(word);
    return node >= 0 && doc->nodes[node].type == JSON_STRING && doc->nodes[node].length == n &&
           memcmp(doc->nodes[node].text, word, n) == 0;
}
