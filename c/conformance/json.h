/* A minimal JSON reader for the conformance program only (test tooling, not the library). */
#ifndef NURIMC_CONFORMANCE_JSON_H
#define NURIMC_CONFORMANCE_JSON_H

#include <stddef.h>

typedef enum { JSON_NULL, JSON_BOOL, JSON_INT, JSON_FLOAT, JSON_STRING, JSON_ARRAY, JSON_OBJECT } json_type;

typedef struct json_node {
    json_type type;
    long value;        /* JSON_INT (saturated to the range of long) and JSON_BOOL */
    double number;     /* JSON_INT and JSON_FLOAT: the nearest double (strtod; +-HUGE_VAL beyond) */
    const char *text;  /* JSON_STRING: unescaped, NUL-terminated, in the input buffer */
    size_t length;     /* JSON_STRING: bytes in text (a \u0000 inside counts; strings compare whole) */
    const char *key;   /* the member name when the parent is an object */
    size_t key_length; /* bytes in key */
    int first_child;   /* index of the first element/member, -1 if none */
    int next_sibling;  /* index of the next element/member, -1 if none */
} json_node;

typedef struct json_doc {
    json_node *nodes;
    int count, capacity;
    char error[96];
} json_doc;

#define JSON_MAX_DEPTH 64 /* the request object is level 1 (conformance/README.md) */

/* Parse `text` (NUL-terminated, modified in place: strings are unescaped there). Strict
 * RFC 8259; lone surrogate escapes and nesting beyond JSON_MAX_DEPTH are errors.
 * Returns 0, or -1 with doc->error. */
int json_parse(json_doc *doc, char *text);
void json_free(json_doc *doc);
/* The last member named `key` of object node `object` (JSON takes the last duplicate), or -1. */
int json_member(const json_doc *doc, int object, const char *key);
/* 1 if string node `node` is exactly `word` (a NUL inside the string never matches). */
int json_string_is(const json_doc *doc, int node, const char *word);

#endif
