/*
 * libFuzzer target: decode and the stream parser on arbitrary bytes. Checks, besides the
 * sanitizers: chunking never changes the result; every byte is a frame's or dropped; a
 * decoded frame re-encodes to the same bytes (or its values are out of range).
 */
#include <stdlib.h>
#include <string.h>

#include "nurimc.h"

typedef struct tally {
    size_t frames, frame_bytes;
    unsigned long hash;
} tally;

static void count(void *context, const nurimc_message *msg) {
    tally *t = context;
    int i;
    t->frames++;
    t->frame_bytes += nurimc_spec(msg->type)->size + 4u;
    t->hash = t->hash * 31u + (unsigned long)msg->type * 7u + msg->id;
    for (i = 0; i < nurimc_spec(msg->type)->field_count; i++) t->hash = t->hash * 31u + nurimc_get_field(msg, i);
}

static void run(const uint8_t *data, size_t size, size_t chunk, tally *t, nurimc_parser_stats *stats) {
    nurimc_parser parser;
    nurimc_message msg;
    size_t at = 0;
    memset(t, 0, sizeof *t);
    nurimc_parser_init(&parser);
    while (at < size) {
        size_t n = size - at < chunk ? size - at : chunk;
        nurimc_parser_feed(&parser, data + at, n, count, t);
        if (nurimc_parser_pending(&parser) >= NURIMC_MAX_FRAME_LENGTH) abort();
        at += n;
    }
    while (nurimc_parser_finish(&parser, &msg)) count(t, &msg);
    *stats = parser.stats;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    nurimc_message msg;
    tally whole, pieces;
    nurimc_parser_stats whole_stats, piece_stats;
    size_t chunk = size > 0 ? (size_t)(data[0] % 13u) + 1u : 1u;

    if (nurimc_decode(data, size, &msg) == NURIMC_OK) {
        uint8_t again[NURIMC_MAX_FRAME_LENGTH];
        size_t length = 0;
        nurimc_status status = nurimc_encode(&msg, again, sizeof again, &length, NULL);
        if (status == NURIMC_OK && (length != size || memcmp(again, data, size) != 0)) abort();
        if (status != NURIMC_OK && status != NURIMC_E_RANGE) abort();
    }
    run(data, size, size ? size : 1u, &whole, &whole_stats);
    run(data, size, chunk, &pieces, &piece_stats);
    if (whole.frames != pieces.frames || whole.hash != pieces.hash) abort();
    if (memcmp(&whole_stats, &piece_stats, sizeof whole_stats) != 0) abort();
    if (whole.frame_bytes + whole_stats.dropped_bytes != size) abort();
    return 0;
}
