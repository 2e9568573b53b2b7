/*
 * The stream parser. The rule (conformance/README.md): where a whole valid frame starts,
 * take it; otherwise drop one byte and look again from the next. Candidates are rejected
 * as soon as their bytes allow (size byte, mode), so the buffer holds at most one frame.
 */
#include "nurimc.h"

#include <string.h>

void nurimc_unpack_valid(const uint8_t *frame, nurimc_message_type type, nurimc_message *out);

enum verdict { WAIT, REJECT, VALID };

/* Judge the candidate at b[0] (b[0..1] = FF FE, `avail` bytes present). Counts rejections. */
static enum verdict judge(nurimc_parser_stats *stats, const uint8_t *b, size_t avail, nurimc_message *out) {
    uint8_t size;
    uint8_t plus_one;
    if (avail < 4) return WAIT;
    size = b[3];
    if (size < 2 || size > NURIMC_MAX_SIZE) {
        stats->bad_size++;
        return REJECT;
    }
    if (avail < 6) return WAIT;
    plus_one = nurimc_type_by_mode_plus_one[b[5]];
    if (plus_one == 0) {
        stats->unknown_mode++;
        return REJECT;
    }
    if (nurimc_message_specs[plus_one - 1].size != size) {
        stats->bad_size++;
        return REJECT;
    }
    if (avail < (size_t)size + NURIMC_FRAME_OVERHEAD) return WAIT;
    if (b[4] != nurimc_checksum(b, (size_t)size + NURIMC_FRAME_OVERHEAD)) {
        stats->bad_checksum++;
        return REJECT;
    }
    nurimc_unpack_valid(b, (nurimc_message_type)(plus_one - 1), out);
    return VALID;
}

/* Resolve what the buffer allows; returns 1 with *out filled if a frame was taken. */
static int scan(nurimc_parser *p, int final, nurimc_message *out) {
    uint8_t *buf = p->buf;
    size_t n = p->length, pos = 0, start;
    int found = 0;
    while (pos < n) {
        for (start = pos; start + 1 < n; start++) {
            if (buf[start] == NURIMC_HEADER_0 && buf[start + 1] == NURIMC_HEADER_1) break;
        }
        if (start + 1 >= n) { /* no header: keep a last FF that may begin one */
            size_t keep = (!final && buf[n - 1] == NURIMC_HEADER_0) ? 1u : 0u;
            p->stats.dropped_bytes += (uint32_t)(n - keep - pos);
            pos = n - keep;
            break;
        }
        p->stats.dropped_bytes += (uint32_t)(start - pos);
        pos = start;
        if (found) break; /* at most one frame per call; the next call takes this one */
        switch (judge(&p->stats, buf + pos, n - pos, out)) {
        case VALID:
            found = 1;
            p->stats.frames++;
            pos += (size_t)buf[pos + 3] + NURIMC_FRAME_OVERHEAD;
            continue;
        case REJECT:
            p->stats.dropped_bytes++;
            pos++;
            continue;
        case WAIT: break;
        }
        if (!final) break; /* an incomplete candidate: wait for more bytes */
        p->stats.dropped_bytes++;
        pos++;
    }
    if (pos > 0) memmove(buf, buf + pos, n - pos);
    p->length = (uint8_t)(n - pos);
    return found;
}

void nurimc_parser_init(nurimc_parser *parser) {
    if (parser != NULL) memset(parser, 0, sizeof *parser);
}

int nurimc_parser_push(nurimc_parser *parser, uint8_t byte, nurimc_message *out) {
    if (parser == NULL || out == NULL) return 0;
    if (parser->length >= sizeof parser->buf) { /* cannot happen: a full frame is always decided */
        parser->stats.dropped_bytes++;
        memmove(parser->buf, parser->buf + 1, sizeof parser->buf - 1u);
        parser->length--;
    }
    parser->buf[parser->length++] = byte;
    return scan(parser, 0, out);
}

size_t nurimc_parser_feed(nurimc_parser *parser, const uint8_t *data, size_t length, nurimc_frame_callback callback,
                          void *context) {
    size_t i = 0, count = 0;
    nurimc_message msg;
    if (parser == NULL || (data == NULL && length > 0)) return 0;
    while (i < length) {
        if (parser->length == 0) { /* fast path: judge candidates in place, no copy */
            size_t avail = length - i;
            if (data[i] != NURIMC_HEADER_0 || (avail >= 2 && data[i + 1] != NURIMC_HEADER_1)) {
                parser->stats.dropped_bytes++;
                i++;
                continue;
            }
            if (avail >= 2) {
                enum verdict v = judge(&parser->stats, data + i, avail, &msg);
                if (v == VALID) {
                    parser->stats.frames++;
                    i += (size_t)data[i + 3] + NURIMC_FRAME_OVERHEAD;
                    count++;
                    if (callback != NULL) callback(context, &msg);
                    continue;
                }
                if (v == REJECT) {
                    parser->stats.dropped_bytes++;
                    i++;
                    continue;
                }
            }
        }
        if (nurimc_parser_push(parser, data[i++], &msg)) {
            count++;
            if (callback != NULL) callback(context, &msg);
        }
    }
    return count;
}

int nurimc_parser_finish(nurimc_parser *parser, nurimc_message *out) {
    if (parser == NULL || out == NULL || parser->length == 0) return 0;
    return scan(parser, 1, out);
}

void nurimc_parser_clear(nurimc_parser *parser) {
    if (parser == NULL) return;
    parser->stats.dropped_bytes += parser->length;
    parser->length = 0;
}

size_t nurimc_parser_pending(const nurimc_parser *parser) {
    return parser ? parser->length : 0u;
}
