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

/* The rule applied offline to a whole input, independently of the streaming code: at each
   position, judge the candidate there on all the bytes that follow (size byte, mode, the mode's
   size, checksum); take a valid frame and continue after it, else drop one byte. */
static void reference_parse(const uint8_t *data, size_t length, result *r) {
    size_t pos = 0;
    memset(r, 0, sizeof *r);
    while (pos < length) {
        size_t avail = length - pos;
        const uint8_t *b = data + pos;
        nurimc_message msg;
        nurimc_message_type type;
        if (avail < 2 || b[0] != 0xFF || b[1] != 0xFE || avail < 4) {
            r->stats.dropped_bytes++;
            pos++;
            continue;
        }
        if (b[3] < 2 || b[3] > NURIMC_MAX_SIZE) {
            r->stats.bad_size++;
        } else if (avail < 6) {
            /* cut off by the end of the input: dropped, not counted */
        } else if ((type = nurimc_type_by_mode(b[5])) == NURIMC_MSG_NONE) {
            r->stats.unknown_mode++;
        } else if (nurimc_spec(type)->size != b[3]) {
            r->stats.bad_size++;
        } else if (avail < (size_t)b[3] + 4u) {
            /* cut off */
        } else if (nurimc_decode(b, (size_t)b[3] + 4u, &msg) != NURIMC_OK) {
            r->stats.bad_checksum++;
        } else {
            if (r->count < MAX_FRAMES) r->frames[r->count] = msg;
            r->count++;
            r->stats.frames++;
            pos += (size_t)b[3] + 4u;
            continue;
        }
        r->stats.dropped_bytes++;
        pos++;
    }
}

/* Random streams of frames, corrupted frames (one flipped bit), fragments, FF FE pairs and
   noise: push, feed in every chunking and the offline rule give the same frames and counters. */
static void test_matches_offline_rule(void) {
    uint32_t seed = 2024;
    int round;
    for (round = 0; round < 2000; round++) {
        uint8_t data[200];
        size_t n = 0;
        result online, offline;
        while (n + NURIMC_MAX_FRAME_LENGTH < sizeof data) {
            seed = seed * 1103515245u + 12345u;
            switch ((seed >> 16) % 6) {
            case 0: data[n++] = (uint8_t)(seed >> 8); break;
            case 1: data[n++] = 0xFF; break;
            case 2: data[n++] = 0xFE; break;
            default: {
                nurimc_message msg = nurimc_message_init((nurimc_message_type)((seed >> 8) % NURIMC_MESSAGE_COUNT), 3);
                const nurimc_message_spec *spec = nurimc_spec(msg.type);
                size_t frame_length = 0;
                int f;
                for (f = 0; f < spec->field_count; f++) {
                    unsigned span = (unsigned)spec->fields[f].max - spec->fields[f].min + 1u;
                    nurimc_set_field(&msg, f, (uint16_t)(spec->fields[f].min + (seed >> 4) % span));
                }
                CHECK_EQ(nurimc_encode(&msg, data + n, sizeof data - n, &frame_length, NULL), NURIMC_OK);
                if ((seed >> 26) % 4 == 0) { /* one flipped bit after the header */
                    data[n + 2 + (seed >> 9) % (frame_length - 2)] ^= (uint8_t)(1u << ((seed >> 13) % 8));
                }
                if ((seed >> 24) % 5 == 0) frame_length = (seed >> 20) % frame_length; /* a fragment */
                n += frame_length;
            }
            }
        }
        reference_parse(data, n, &offline);
        check_all_chunkings(data, n, &online); /* push, and feed in chunks of 1..13 and all */
        CHECK(same_result(&online, &offline));
    }
}

/* On a clean stream push returns each frame at its last byte, holding nothing after it. */
static void test_push_returns_at_last_byte(void) {
    nurimc_parser parser;
    nurimc_message msg;
    int type;
    nurimc_parser_init(&parser);
    for (type = 0; type < (int)NURIMC_MESSAGE_COUNT; type++) {
        uint8_t frame[NURIMC_MAX_FRAME_LENGTH];
        size_t length = 0, i;
        nurimc_message in = nurimc_message_init((nurimc_message_type)type, 9);
        const nurimc_message_spec *spec = nurimc_spec(in.type);
        int f;
        for (f = 0; f < spec->field_count; f++) nurimc_set_field(&in, f, spec->fields[f].max);
        if (nurimc_encode(&in, frame, sizeof frame, &length, NULL) != NURIMC_OK) {
            CHECK(0);
            return;
        }
        for (i = 0; i + 1 < length; i++) {
            CHECK_EQ(nurimc_parser_push(&parser, frame[i], &msg), 0);
            CHECK_EQ(nurimc_parser_pending(&parser), i + 1);
        }
        CHECK_EQ(nurimc_parser_push(&parser, frame[length - 1], &msg), 1);
        CHECK_EQ(msg.type, (nurimc_message_type)type);
        CHECK_EQ(msg.id, 9);
        CHECK_EQ(nurimc_parser_pending(&parser), 0);
    }
    CHECK_EQ(parser.stats.frames, NURIMC_MESSAGE_COUNT);
    CHECK_EQ(parser.stats.dropped_bytes, 0);
}

/* A wrong size byte is judged with the mode byte: counted once, as a bad size, and the bytes
   after it are looked at again (here a frame starts at the candidate's checksum byte). */
static void test_bad_size_judged_with_mode(void) {
    const uint8_t data[] = {0xFF, 0xFE, 0x00, 0x09, 0xFF, 0xFE, 0x00, 0x02, 0x5D, 0xA0};
    nurimc_parser parser;
    nurimc_message msg;
    size_t i;
    result r;
    check_all_chunkings(data, sizeof data, &r);
    CHECK_EQ(r.count, 1);
    CHECK_EQ(r.frames[0].type, NURIMC_MSG_REQUEST_PING);
    CHECK_EQ(r.stats.bad_size, 1);
    CHECK_EQ(r.stats.dropped_bytes, 4);
    nurimc_parser_init(&parser);
    for (i = 0; i + 1 < sizeof data; i++) CHECK_EQ(nurimc_parser_push(&parser, data[i], &msg), 0);
    CHECK_EQ(nurimc_parser_push(&parser, data[sizeof data - 1], &msg), 1);
    CHECK_EQ(msg.type, NURIMC_MSG_REQUEST_PING);
    CHECK_EQ(parser.stats.bad_size, 1);
    CHECK_EQ(nurimc_parser_pending(&parser), 0);
}

/* FE is judged with the mode byte, with the size byte: a candidate whose second byte is not FE
   is dropped then, and a frame starting inside it is still returned at its last byte. */
static void test_missing_fe_judged_with_mode(void) {
    static const uint8_t ping[] = {0xFF, 0xFE, 0x00, 0x02, 0x5D, 0xA0};
    static const uint8_t prefixes[][6] = {{0xFF},
                                          {0xFF, 0x00},
                                          {0xFF, 0xFF},
                                          {0xFF, 0x00, 0xFF},
                                          {0xFF, 0x01, 0x02, 0x03},
                                          {0xFF, 0xFF, 0xFF},
                                          {0xFF, 0xFD, 0xFF, 0xFF},
                                          {0xFF, 0x00, 0x00, 0x02, 0x5D, 0xA0}}; /* the last: a ping with 00 for FE */
    static const size_t prefix_lengths[] = {1, 2, 2, 3, 4, 3, 4, 6};
    size_t k;
    for (k = 0; k < sizeof prefix_lengths / sizeof prefix_lengths[0]; k++) {
        uint8_t data[16];
        size_t length = prefix_lengths[k] + sizeof ping, i;
        nurimc_parser parser;
        nurimc_message msg;
        result r;
        memcpy(data, prefixes[k], prefix_lengths[k]);
        memcpy(data + prefix_lengths[k], ping, sizeof ping);
        check_all_chunkings(data, length, &r);
        CHECK_EQ(r.count, 1);
        CHECK_EQ(r.frames[0].type, NURIMC_MSG_REQUEST_PING);
        CHECK_EQ(r.stats.dropped_bytes, prefix_lengths[k]);
        nurimc_parser_init(&parser);
        for (i = 0; i + 1 < length; i++) CHECK_EQ(nurimc_parser_push(&parser, data[i], &msg), 0);
        CHECK_EQ(nurimc_parser_push(&parser, data[length - 1], &msg), 1);
        CHECK_EQ(msg.type, NURIMC_MSG_REQUEST_PING);
        CHECK_EQ(nurimc_parser_pending(&parser), 0);
        CHECK_EQ(parser.stats.dropped_bytes, prefix_lengths[k]);
    }
}

/* nurimc_parser_push (inline) and nurimc_parser_push_checked (out of line) are one parser; a
   NULL parser or out ignores the byte, in the inline fast path (mid-frame) too. */
static void test_push_checked_and_null(void) {
    static const uint8_t data[] = {0x00, 0xFF, 0xFE, 0x00, 0x02, 0x5D, 0xA0, 0xFF, 0xFE, 0x00,
                                   0x77, 0x00, 0xA0, 0xFF, 0xFE, 0x00, 0x02, 0x5D, 0xA0};
    nurimc_parser a, b;
    nurimc_message ma, mb;
    size_t i;
    nurimc_parser *none = NULL;
    nurimc_message *no_out = NULL;
    nurimc_parser_init(&a);
    nurimc_parser_init(&b);
    for (i = 0; i < sizeof data; i++) {
        int got_a = nurimc_parser_push(&a, data[i], &ma);
        int got_b = nurimc_parser_push_checked(&b, data[i], &mb);
        CHECK_EQ(got_a, got_b);
        if (got_a && got_b) CHECK_EQ(ma.type, mb.type);
        CHECK_EQ(nurimc_parser_pending(&a), nurimc_parser_pending(&b));
        CHECK_EQ(nurimc_parser_push(&a, 0xFF, no_out), 0); /* ignored: held bytes unchanged */
        CHECK_EQ(nurimc_parser_push_checked(&b, 0xFF, no_out), 0);
        CHECK_EQ(nurimc_parser_pending(&a), nurimc_parser_pending(&b));
        CHECK_EQ(nurimc_parser_push(none, data[i], &ma), 0);
        CHECK_EQ(nurimc_parser_push_checked(none, data[i], &mb), 0);
    }
    CHECK_EQ(a.stats.frames, 2);
    CHECK_EQ(memcmp(&a.stats, &b.stats, sizeof a.stats), 0);
    CHECK_EQ(a.stats.dropped_bytes, 7);
}

int main(void) {
    test_noise_and_frames();
    test_bad_checksum_hides_no_frame();
    test_unknown_mode_counted();
    test_partial_frame_at_end();
    test_clear_counts_dropped();
    test_random_streams();
    test_matches_offline_rule();
    test_push_returns_at_last_byte();
    test_bad_size_judged_with_mode();
    test_missing_fe_judged_with_mode();
    test_push_checked_and_null();
    return check_report("test_parser");
}
