/* The stream parser: chunking independence, resynchronisation, counted diagnostics, bounds. */
#include <string.h>

#include "check.h"
#include "nurimc.h"

#define MAX_FRAMES 256

typedef struct result {
    nurimc_message frames[MAX_FRAMES];
    int count;
    nurimc_parser_stats stats;
} result;

static void collect(void *context, const nurimc_message *msg) {
    result *r = context;
    if (r->count < MAX_FRAMES) r->frames[r->count] = *msg;
    r->count++;
}

/* Parse `data` fed in chunks of `chunk` bytes (0: one byte at a time through push). */
static void parse(const uint8_t *data, size_t length, size_t chunk, result *r) {
    nurimc_parser parser;
    nurimc_message msg;
    size_t at = 0;
    memset(r, 0, sizeof *r);
    nurimc_parser_init(&parser);
    if (chunk == 0) {
        for (at = 0; at < length; at++) {
            if (nurimc_parser_push(&parser, data[at], &msg)) collect(r, &msg);
            CHECK(nurimc_parser_pending(&parser) < NURIMC_MAX_FRAME_LENGTH);
        }
    } else {
        while (at < length) {
            size_t n = length - at < chunk ? length - at : chunk;
            nurimc_parser_feed(&parser, data + at, n, collect, r);
            CHECK(nurimc_parser_pending(&parser) < NURIMC_MAX_FRAME_LENGTH);
            at += n;
        }
    }
    while (nurimc_parser_finish(&parser, &msg)) collect(r, &msg);
    CHECK_EQ(nurimc_parser_pending(&parser), 0);
    r->stats = parser.stats;
}

static size_t frame_bytes(const result *r) {
    size_t total = 0;
    int i;
    for (i = 0; i < r->count && i < MAX_FRAMES; i++) total += nurimc_spec(r->frames[i].type)->size + 4u;
    return total;
}

static int same_result(const result *a, const result *b) {
    int i;
    if (a->count != b->count || memcmp(&a->stats, &b->stats, sizeof a->stats) != 0) return 0;
    for (i = 0; i < a->count && i < MAX_FRAMES; i++) {
        const nurimc_message *x = &a->frames[i], *y = &b->frames[i];
        int f;
        if (x->type != y->type || x->id != y->id) return 0;
        for (f = 0; f < nurimc_spec(x->type)->field_count; f++) {
            if (nurimc_get_field(x, f) != nurimc_get_field(y, f)) return 0;
        }
    }
    return 1;
}

/* Every chunking gives the same frames and stats, and every byte is a frame's or dropped. */
static void check_all_chunkings(const uint8_t *data, size_t length, result *whole) {
    size_t chunk;
    parse(data, length, length ? length : 1, whole);
    CHECK_EQ(frame_bytes(whole) + whole->stats.dropped_bytes, length);
    CHECK_EQ(whole->stats.frames, whole->count);
    for (chunk = 0; chunk <= 13; chunk++) {
        result other;
        parse(data, length, chunk, &other);
        CHECK(same_result(whole, &other));
    }
}

static const uint8_t ping_request[] = {0xFF, 0xFE, 0x00, 0x02, 0x5D, 0xA0};
static const uint8_t position_feedback[] = {0xFF, 0xFE, 0x07, 0x08, 0x89, 0xD1, 0x00, 0x46, 0x50, 0x00, 0x00, 0x00};

static void test_noise_and_frames(void) {
    uint8_t data[64];
    size_t n = 0;
    result r;
    data[n++] = 0x00;
    data[n++] = 0xFF; /* a lone FF, then a false header with a size no message has */
    data[n++] = 0xFF;
    data[n++] = 0xFE;
    data[n++] = 0x01;
    data[n++] = 0x40;
    memcpy(data + n, ping_request, sizeof ping_request);
    n += sizeof ping_request;
    memcpy(data + n, position_feedback, sizeof position_feedback);
    n += sizeof position_feedback;
    data[n++] = 0x55;
    check_all_chunkings(data, n, &r);
    CHECK_EQ(r.count, 2);
    CHECK_EQ(r.frames[0].type, NURIMC_MSG_REQUEST_PING);
    CHECK_EQ(r.frames[1].type, NURIMC_MSG_POSITION_FEEDBACK);
    CHECK_EQ(r.frames[1].id, 7);
    CHECK_EQ(r.frames[1].u.position_feedback.position, 18000);
    CHECK_EQ(r.stats.dropped_bytes, 7);
    CHECK_EQ(r.stats.bad_size, 1);
}

static void test_bad_checksum_hides_no_frame(void) {
    /* A candidate with a bad checksum whose data holds a real frame: the frame is found. */
    uint8_t data[12] = {0xFF, 0xFE, 0x07, 0x08, 0x00, 0xD1};
    result r;
    memcpy(data + 6, ping_request, sizeof ping_request);
    check_all_chunkings(data, sizeof data, &r);
    CHECK_EQ(r.count, 1);
    CHECK_EQ(r.frames[0].type, NURIMC_MSG_REQUEST_PING);
    CHECK_EQ(r.stats.bad_checksum, 1);
    CHECK_EQ(r.stats.dropped_bytes, 6);
}

static void test_unknown_mode_counted(void) {
    const uint8_t data[] = {0xFF, 0xFE, 0x00, 0x02, 0xFD, 0x00};
    result r;
    check_all_chunkings(data, sizeof data, &r);
    CHECK_EQ(r.count, 0);
    CHECK_EQ(r.stats.unknown_mode, 1);
    CHECK_EQ(r.stats.dropped_bytes, 6);
}

static void test_partial_frame_at_end(void) {
    /* 12 bytes: the outer candidate (size 8) is complete but its checksum is wrong; the ping inside is found. */
    const uint8_t whole[] = {0xFF, 0xFE, 0x07, 0x08, 0x89, 0xD1, 0xFF, 0xFE, 0x00, 0x02, 0x5D, 0xA0};
    /* The same cut after 10 bytes: the outer candidate could still be a frame, so the parser holds
       it; at the end of the stream it is dropped byte by byte and the partial ping with it. */
    const uint8_t cut[] = {0xFF, 0xFE, 0x07, 0x08, 0x89, 0xD1, 0xFF, 0xFE, 0x00, 0x02};
    nurimc_parser parser;
    nurimc_message msg;
    result r;
    check_all_chunkings(whole, sizeof whole, &r);
    CHECK_EQ(r.count, 1);
    CHECK_EQ(r.frames[0].type, NURIMC_MSG_REQUEST_PING);
    CHECK_EQ(r.stats.bad_checksum, 1);

    nurimc_parser_init(&parser);
    CHECK_EQ(nurimc_parser_feed(&parser, cut, sizeof cut, NULL, NULL), 0);
    CHECK_EQ(nurimc_parser_pending(&parser), sizeof cut);
    CHECK_EQ(parser.stats.dropped_bytes, 0);
    CHECK_EQ(nurimc_parser_finish(&parser, &msg), 0);
    CHECK_EQ(nurimc_parser_pending(&parser), 0);
    CHECK_EQ(parser.stats.dropped_bytes, sizeof cut);
    /* Completed later, the held candidate is judged whole: bad checksum, then the ping. */
    nurimc_parser_init(&parser);
    nurimc_parser_feed(&parser, cut, sizeof cut, NULL, NULL);
    CHECK_EQ(nurimc_parser_push(&parser, 0x5D, &msg), 0);
    CHECK_EQ(nurimc_parser_push(&parser, 0xA0, &msg), 1);
    CHECK_EQ(msg.type, NURIMC_MSG_REQUEST_PING);
    CHECK_EQ(parser.stats.bad_checksum, 1);
}

static void test_clear_counts_dropped(void) {
    nurimc_parser parser;
    nurimc_message msg;
    nurimc_parser_init(&parser);
    CHECK_EQ(nurimc_parser_push(&parser, 0xFF, &msg), 0);
    CHECK_EQ(nurimc_parser_push(&parser, 0xFE, &msg), 0);
    CHECK_EQ(nurimc_parser_pending(&parser), 2);
    nurimc_parser_clear(&parser);
    CHECK_EQ(nurimc_parser_pending(&parser), 0);
    CHECK_EQ(parser.stats.dropped_bytes, 2);
}

/* Pseudo-random streams (frames, fragments and noise): the invariants hold for all chunkings. */
static void test_random_streams(void) {
    uint32_t seed = 12345;
    int round;
    for (round = 0; round < 300; round++) {
        uint8_t data[400];
        size_t n = 0;
        result r;
        while (n + NURIMC_MAX_FRAME_LENGTH < sizeof data) {
            seed = seed * 1103515245u + 12345u;
            switch ((seed >> 16) % 4) {
            case 0: data[n++] = (uint8_t)(seed >> 8); break;
            case 1: data[n++] = 0xFF; break;
            default: {
                nurimc_message msg = nurimc_message_init((nurimc_message_type)((seed >> 8) % NURIMC_MESSAGE_COUNT), 1);
                const nurimc_message_spec *spec = nurimc_spec(msg.type);
                size_t length = 0;
                int f;
                for (f = 0; f < spec->field_count; f++) nurimc_set_field(&msg, f, spec->fields[f].min);
                nurimc_encode(&msg, data + n, sizeof data - n, &length, NULL);
                if ((seed >> 24) % 5 == 0 && length > 0) length = (seed >> 20) % length; /* a fragment */
                n += length;
            }
            }
        }
        check_all_chunkings(data, n, &r);
    }
}

int main(void) {
    test_noise_and_frames();
    test_bad_checksum_hides_no_frame();
    test_unknown_mode_counted();
    test_partial_frame_at_end();
    test_clear_counts_dropped();
    test_random_streams();
    return check_report("test_parser");
}
